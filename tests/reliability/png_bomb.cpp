#include "png_bomb.h"

#include <zlib.h>

#include <stdexcept>
#include <vector>

namespace arscout::testing {
namespace {

void put32(std::string& out, unsigned long v) {
  for (int shift = 24; shift >= 0; shift -= 8)
    out.push_back(static_cast<char>((v >> shift) & 0xFF));
}

void chunk(std::string& out, const std::string& type, const std::string& data) {
  put32(out, data.size());
  const std::string body = type + data;
  out += body;
  put32(out, crc32(0, reinterpret_cast<const Bytef*>(body.data()),
                   static_cast<uInt>(body.size())));
}

std::string header(int width, int height, int colour_type, int bit_depth) {
  std::string png("\x89PNG\r\n\x1a\n", 8);
  std::string ihdr;
  put32(ihdr, width);
  put32(ihdr, height);
  ihdr += static_cast<char>(bit_depth);
  ihdr += static_cast<char>(colour_type);
  ihdr += std::string(3, '\0');  // deflate, adaptive filtering, no interlace
  chunk(png, "IHDR", ihdr);
  return png;
}

// The rows (a filter byte and zero samples each), deflated row by row.
std::string zero_idat(int width, int height, int channels, int bytes) {
  z_stream z{};
  if (deflateInit(&z, 1) != Z_OK) throw std::runtime_error("deflateInit");
  const std::vector<Bytef> row(
      1 + static_cast<size_t>(width) * channels * bytes, 0);
  std::string out;
  std::vector<Bytef> buffer(1 << 16);
  for (int y = 0; y <= height; ++y) {
    const bool last = y == height;
    z.next_in = const_cast<Bytef*>(row.data());
    z.avail_in = last ? 0 : static_cast<uInt>(row.size());
    do {
      z.next_out = buffer.data();
      z.avail_out = static_cast<uInt>(buffer.size());
      deflate(&z, last ? Z_FINISH : Z_NO_FLUSH);
      out.append(reinterpret_cast<char*>(buffer.data()),
                 buffer.size() - z.avail_out);
    } while (z.avail_out == 0);
  }
  deflateEnd(&z);
  return out;
}

int channels_of(int colour_type) { return colour_type == 6 ? 4 : 3; }

}  // namespace

std::string zero_png(int width, int height, int colour_type, int bit_depth,
                     bool bad_ztxt) {
  std::string png = header(width, height, colour_type, bit_depth);
  // keyword, NUL, compression method 7 (only 0 exists), then junk.
  if (bad_ztxt) chunk(png, "zTXt", std::string("Comment\0\x07junk", 13));
  chunk(png, "IDAT",
        zero_idat(width, height, channels_of(colour_type), bit_depth / 8));
  chunk(png, "IEND", "");
  return png;
}

std::string png_header_only(int width, int height, int colour_type,
                            int bit_depth) {
  std::string png = header(width, height, colour_type, bit_depth);
  chunk(png, "IDAT", std::string("\x78\x01", 2));
  chunk(png, "IEND", "");
  return png;
}

}  // namespace arscout::testing
