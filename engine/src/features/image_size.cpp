#include "arscout/engine/image_size.h"

#include "arscout/util/image_header.h"

namespace arscout::engine {

std::optional<ImageSize> read_image_size(std::string_view encoded) {
  const auto header = util::read_image_header(encoded);
  if (!header) return std::nullopt;
  return ImageSize{static_cast<int>(header->width),
                   static_cast<int>(header->height)};
}

}  // namespace arscout::engine
