// util::read_image_header on headers written here byte by byte: what the
// engine's sizes and the upload decode budget both read (their own tests
// cover real files, truncation and garbage: ImageSizeTest, HostileClients).
#include "arscout/util/image_header.h"

#include <string>

#include <gtest/gtest.h>

namespace arscout::util {
namespace {

// A PNG signature and IHDR for width x height, depth and colour type,
// cut to `length` bytes.
std::string png(unsigned width, unsigned height, int depth, int colour,
                std::size_t length = 33) {
  std::string b("\x89PNG\r\n\x1a\n\x00\x00\x00\x0dIHDR", 16);
  for (unsigned v : {width, height})
    for (int shift = 24; shift >= 0; shift -= 8)
      b.push_back(static_cast<char>((v >> shift) & 0xFF));
  b.push_back(static_cast<char>(depth));
  b.push_back(static_cast<char>(colour));
  b.append(7, '\0');  // compression, filter, interlace, CRC
  return b.substr(0, length);
}

TEST(ImageHeader, PngSaysSizeChannelsAndDepth) {
  const auto rgba16 = read_image_header(png(640, 480, 16, 6));
  ASSERT_TRUE(rgba16);
  EXPECT_EQ(rgba16->width, 640);
  EXPECT_EQ(rgba16->height, 480);
  EXPECT_EQ(rgba16->channels, 4);
  EXPECT_EQ(rgba16->bytes_per_channel, 2);
  EXPECT_EQ(rgba16->decoded_bytes(), 640LL * 480 * 4 * 2);
  EXPECT_EQ(read_image_header(png(3, 2, 8, 0))->channels, 1);
  EXPECT_EQ(read_image_header(png(3, 2, 8, 3))->channels, 3);
  // The size without the colour type: channels unknown (0).
  const auto cut = read_image_header(png(3, 2, 8, 2, 24));
  ASSERT_TRUE(cut);
  EXPECT_EQ(cut->channels, 0);
  EXPECT_FALSE(read_image_header(png(3, 2, 8, 2, 23)));
  EXPECT_EQ(read_image_header(png(3, 2, 8, 5))->channels, 0);  // unknown
  EXPECT_FALSE(read_image_header(png(0, 2, 8, 2)));
  EXPECT_FALSE(read_image_header(png((1u << 30) + 1, 2, 8, 2)));
}

TEST(ImageHeader, JpegStopsAtAScanBeforeTheFrame) {
  // SOI, SOF0 of 7 x 5 with 3 components at 8 bits.
  const std::string sof("\xFF\xC0\x00\x11\x08\x00\x05\x00\x07\x03", 10);
  const auto h = read_image_header(std::string("\xFF\xD8", 2) + sof);
  ASSERT_TRUE(h);
  EXPECT_EQ(h->width, 7);
  EXPECT_EQ(h->height, 5);
  EXPECT_EQ(h->channels, 3);
  // The same frame after a start-of-scan: nothing (a scan comes after it).
  const std::string sos("\xFF\xDA\x00\x08\x01\x01\x00\x00\x3F\x00", 10);
  EXPECT_FALSE(read_image_header(std::string("\xFF\xD8", 2) + sos + sof));
  EXPECT_FALSE(read_image_header("GIF89a"));
}

}  // namespace
}  // namespace arscout::util
