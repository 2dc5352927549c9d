// Reading a photo's size from its header, against images encoded here by
// OpenCV (whose decoder is the reference for what the sizes are) and
// hand-made or damaged headers.
#include "arscout/engine/image_size.h"

#include <algorithm>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

namespace arscout::engine {
namespace {

std::string encode(const cv::Mat& image, const std::string& ext,
                   const std::vector<int>& params = {}) {
  std::vector<uchar> bytes;
  EXPECT_TRUE(cv::imencode(ext, image, bytes, params));
  return std::string(bytes.begin(), bytes.end());
}

// Not a flat image: some encoders special-case those.
cv::Mat noise_image(int width, int height, int type) {
  cv::Mat image(height, width, type);
  cv::randu(image, 0, 255);
  return image;
}

void expect_size(const std::optional<ImageSize>& size, int width, int height) {
  ASSERT_TRUE(size.has_value());
  EXPECT_EQ(size->width, width);
  EXPECT_EQ(size->height, height);
}

struct Case {
  int width, height, type;
};
// Odd sizes, portrait and landscape, a single row or column, and sizes over
// 255 so that both bytes of each 16-bit field matter.
const Case kCases[] = {{333, 217, CV_8UC3}, {217, 333, CV_8UC3},
                       {1, 1, CV_8UC1},     {1001, 3, CV_8UC1},
                       {3, 1001, CV_8UC3},  {4097, 2, CV_8UC3},
                       {257, 511, CV_8UC1}};

TEST(ImageSizeTest, ReadsJpegSize) {
  for (const Case& c : kCases) {
    SCOPED_TRACE(std::to_string(c.width) + "x" + std::to_string(c.height));
    expect_size(
        read_image_size(encode(noise_image(c.width, c.height, c.type), ".jpg")),
        c.width, c.height);
  }
}

TEST(ImageSizeTest, ReadsProgressiveJpegSize) {
  // Progressive JPEGs carry their size in SOF2, not SOF0.
  const std::string jpeg = encode(noise_image(641, 479, CV_8UC3), ".jpg",
                                  {cv::IMWRITE_JPEG_PROGRESSIVE, 1});
  ASSERT_NE(jpeg.find("\xFF\xC2", 0, 2), std::string::npos);
  expect_size(read_image_size(jpeg), 641, 479);
}

TEST(ImageSizeTest, ReadsPngSize) {
  for (const Case& c : kCases) {
    SCOPED_TRACE(std::to_string(c.width) + "x" + std::to_string(c.height));
    expect_size(
        read_image_size(encode(noise_image(c.width, c.height, c.type), ".png")),
        c.width, c.height);
  }
}

TEST(ImageSizeTest, SkipsSegmentsBeforeTheFrame) {
  // SOI, an APP1 segment whose payload holds bytes that look like a SOF
  // marker, DHT (0xC4, in the SOF range but not a frame), DAC (0xCC), fill
  // bytes, then SOF0 for a 5 x 7 image.
  const std::string header(
      "\xFF\xD8"
      "\xFF\xE1\x00\x08\xFF\xC0\x00\x11\x08\x01"
      "\xFF\xC4\x00\x04\x00\x00"
      "\xFF\xCC\x00\x04\x00\x00"
      "\xFF\xFF"
      "\xFF\xC0\x00\x11\x08\x00\x07\x00\x05\x03\x01\x22\x00\x02\x11\x01\x03\x11"
      "\x01",
      2 + 10 + 6 + 6 + 2 + 19);
  expect_size(read_image_size(header), 5, 7);
}

TEST(ImageSizeTest, GarbageGivesNothing) {
  EXPECT_FALSE(read_image_size("").has_value());
  EXPECT_FALSE(read_image_size("hello, world").has_value());
  EXPECT_FALSE(read_image_size(std::string(100, '\0')).has_value());
  EXPECT_FALSE(read_image_size(std::string(100, '\xFF')).has_value());
  std::mt19937 rng(1);
  std::uniform_int_distribution<int> byte(0, 255);
  for (int trial = 0; trial < 200; ++trial) {
    std::string bytes(1 + trial * 7, '\0');
    for (char& b : bytes) b = static_cast<char>(byte(rng));
    // Random bytes behind a JPEG or PNG signature must not crash; they may
    // by chance spell out a size, which is then positive.
    for (const std::string& prefix :
         {std::string("\xFF\xD8", 2), std::string("\x89PNG\r\n\x1a\n")}) {
      const auto size = read_image_size(prefix + bytes);
      if (size) {
        EXPECT_GT(size->width, 0);
        EXPECT_GT(size->height, 0);
      }
    }
    if (bytes.size() >= 2 && static_cast<unsigned char>(bytes[0]) == 0xFF &&
        static_cast<unsigned char>(bytes[1]) == 0xD8) {
      continue;
    }
    if (bytes.rfind("\x89PNG", 0) == 0) continue;
    EXPECT_FALSE(read_image_size(bytes).has_value());
  }
  // A zero size in an otherwise valid PNG header.
  std::string png = encode(noise_image(9, 9, CV_8UC1), ".png");
  png[16] = png[17] = png[18] = png[19] = '\0';
  EXPECT_FALSE(read_image_size(png).has_value());
  // A PNG whose first chunk is not IHDR.
  png = encode(noise_image(9, 9, CV_8UC1), ".png");
  png.replace(12, 4, "IDAT");
  EXPECT_FALSE(read_image_size(png).has_value());
}

// Every prefix of a real file: too short to hold the size, nothing; long
// enough, exactly the size. Never a wrong size, never a read past the end.
void check_prefixes(const std::string& encoded, int width, int height) {
  size_t first_complete = encoded.size() + 1;
  for (size_t length = 0; length <= std::min<size_t>(encoded.size(), 2000);
       ++length) {
    // A buffer of exactly this length, so that a read past its end is a
    // heap overflow the sanitizer build reports.
    const std::vector<char> prefix(encoded.begin(), encoded.begin() + length);
    const auto size =
        read_image_size(std::string_view(prefix.data(), prefix.size()));
    if (size) {
      ASSERT_EQ(size->width, width) << "prefix " << length;
      ASSERT_EQ(size->height, height) << "prefix " << length;
      first_complete = std::min(first_complete, length);
    } else {
      ASSERT_GT(first_complete, length)
          << "prefix " << length << " lost the size";
    }
  }
  // The size sits in the header, after the signature and at least one
  // segment or chunk header - not at the very start, not past 2000 bytes.
  EXPECT_GT(first_complete, 20u);
  EXPECT_LE(first_complete, 2000u);
}

TEST(ImageSizeTest, TruncatedHeadersGiveNothing) {
  {
    SCOPED_TRACE("jpeg");
    check_prefixes(encode(noise_image(333, 217, CV_8UC3), ".jpg"), 333, 217);
  }
  {
    SCOPED_TRACE("png");
    const std::string png = encode(noise_image(333, 217, CV_8UC3), ".png");
    check_prefixes(png, 333, 217);
    // The IHDR size fields end at byte 24.
    EXPECT_FALSE(
        read_image_size(std::string_view(png).substr(0, 23)).has_value());
    EXPECT_TRUE(
        read_image_size(std::string_view(png).substr(0, 24)).has_value());
  }
}

}  // namespace
}  // namespace arscout::engine
