#include "arscout/util/image_header.h"

#include <cstdint>

namespace arscout::util {
namespace {

constexpr std::uint32_t kMaxSide = 1u << 30;

std::uint32_t big_endian(std::string_view b, std::size_t at, int length) {
  std::uint32_t value = 0;
  for (int i = 0; i < length; ++i)
    value = (value << 8) | static_cast<unsigned char>(b[at + i]);
  return value;
}

bool is_start_of_frame(unsigned marker) {
  // SOF0-SOF15, except DHT (C4), JPG (C8) and DAC (CC), which share the range.
  return marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 &&
         marker != 0xCC;
}

// The start-of-frame segment at `at`: precision, height, width, components.
std::optional<ImageHeader> frame_header(std::string_view b, std::size_t at) {
  if (at + 9 > b.size()) return std::nullopt;
  ImageHeader h;
  h.bytes_per_channel = static_cast<unsigned char>(b[at + 4]) > 8 ? 2 : 1;
  h.height = big_endian(b, at + 5, 2);
  h.width = big_endian(b, at + 7, 2);
  if (at + 10 <= b.size()) h.channels = static_cast<unsigned char>(b[at + 9]);
  return h;
}

std::optional<ImageHeader> jpeg_header(std::string_view b) {
  std::size_t at = 2;
  while (at + 4 <= b.size()) {
    if (static_cast<unsigned char>(b[at]) != 0xFF) return std::nullopt;
    const unsigned marker = static_cast<unsigned char>(b[at + 1]);
    if (marker == 0xFF) {  // fill byte
      ++at;
      continue;
    }
    if (marker == 0xD8 || (marker >= 0xD0 && marker <= 0xD7) ||
        marker == 0x01) {
      at += 2;  // markers without a length
      continue;
    }
    if (is_start_of_frame(marker)) return frame_header(b, at);
    const std::uint32_t length = big_endian(b, at + 2, 2);
    if (marker == 0xDA || length < 2) return std::nullopt;  // scan first
    at += 2 + length;
  }
  return std::nullopt;
}

// IHDR: width, height, bit depth, colour type.
std::optional<ImageHeader> png_header(std::string_view b) {
  if (b.size() < 24 || b.substr(12, 4) != "IHDR") return std::nullopt;
  ImageHeader h;
  h.width = big_endian(b, 16, 4);
  h.height = big_endian(b, 20, 4);
  if (b.size() < 26) return h;
  h.bytes_per_channel = static_cast<unsigned char>(b[24]) == 16 ? 2 : 1;
  switch (static_cast<unsigned char>(b[25])) {
    case 0:
      h.channels = 1;
      break;  // grey
    case 2:
      h.channels = 3;
      break;  // RGB
    case 3:
      h.channels = 3;
      break;  // palette, decoded to BGR
    case 4:
      h.channels = 2;
      break;  // grey + alpha
    case 6:
      h.channels = 4;
      break;  // RGBA
    default:
      break;  // unknown: 0
  }
  return h;
}

}  // namespace

std::optional<ImageHeader> read_image_header(std::string_view bytes) {
  std::optional<ImageHeader> h;
  if (bytes.substr(0, 2) == std::string_view("\xFF\xD8", 2))
    h = jpeg_header(bytes);
  else if (bytes.substr(0, 8) == std::string_view("\x89PNG\r\n\x1a\n", 8))
    h = png_header(bytes);
  if (h && (h->width <= 0 || h->height <= 0 || h->width > kMaxSide ||
            h->height > kMaxSide))
    return std::nullopt;
  return h;
}

}  // namespace arscout::util
