// The pixel size of an encoded photo, read from its header alone (JPEG SOF
// segment, PNG IHDR chunk) without decoding it.
#pragma once

#include <optional>
#include <string_view>

namespace arscout::engine {

struct ImageSize {
  int width = 0;
  int height = 0;
};

// nullopt when the bytes are not a JPEG or PNG whose header says its size.
std::optional<ImageSize> read_image_size(std::string_view encoded);

}  // namespace arscout::engine
