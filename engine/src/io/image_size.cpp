#include "arscout/engine/image_size.h"

#include <cstdint>

namespace arscout::engine {
namespace {

uint32_t big_endian(std::string_view bytes, size_t at, int length) {
  uint32_t value = 0;
  for (int i = 0; i < length; ++i) {
    value = (value << 8) | static_cast<unsigned char>(bytes[at + i]);
  }
  return value;
}

bool is_start_of_frame(unsigned char marker) {
  // SOF0-SOF15, except DHT (C4), JPG (C8) and DAC (CC), which share the range.
  return marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 &&
         marker != 0xCC;
}

std::optional<ImageSize> jpeg_size(std::string_view b) {
  size_t at = 2;
  while (at + 4 <= b.size()) {
    if (static_cast<unsigned char>(b[at]) != 0xFF) return std::nullopt;
    const unsigned char marker = static_cast<unsigned char>(b[at + 1]);
    if (marker == 0xFF) {  // fill byte
      ++at;
      continue;
    }
    if (marker == 0xD8 || (marker >= 0xD0 && marker <= 0xD7) ||
        marker == 0x01) {
      at += 2;  // markers without a length
      continue;
    }
    const uint32_t length = big_endian(b, at + 2, 2);
    if (length < 2) return std::nullopt;
    if (is_start_of_frame(marker)) {
      if (at + 9 > b.size()) return std::nullopt;
      const int height = static_cast<int>(big_endian(b, at + 5, 2));
      const int width = static_cast<int>(big_endian(b, at + 7, 2));
      if (width <= 0 || height <= 0) return std::nullopt;
      return ImageSize{width, height};
    }
    at += 2 + length;
  }
  return std::nullopt;
}

std::optional<ImageSize> png_size(std::string_view b) {
  if (b.size() < 24 || b.substr(12, 4) != "IHDR") return std::nullopt;
  const uint32_t width = big_endian(b, 16, 4), height = big_endian(b, 20, 4);
  if (width == 0 || height == 0 || width > 1u << 30 || height > 1u << 30)
    return std::nullopt;
  return ImageSize{static_cast<int>(width), static_cast<int>(height)};
}

}  // namespace

std::optional<ImageSize> read_image_size(std::string_view encoded) {
  if (encoded.size() > 3 && static_cast<unsigned char>(encoded[0]) == 0xFF &&
      static_cast<unsigned char>(encoded[1]) == 0xD8) {
    return jpeg_size(encoded);
  }
  static constexpr char kPngSignature[] = "\x89PNG\r\n\x1a\n";
  if (encoded.substr(0, 8) == std::string_view(kPngSignature, 8))
    return png_size(encoded);
  return std::nullopt;
}

}  // namespace arscout::engine
