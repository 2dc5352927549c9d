// Validates an uploaded image and reads its size, decoding it once.
#pragma once

#include <string>
#include <string_view>

namespace arscout::ingest {

struct ImageProbe {
  bool ok = false;
  std::string error;   // when !ok: what is wrong, e.g. "truncated JPEG"
  std::string format;  // "jpeg" | "png"
  int width = 0;
  int height = 0;
};

ImageProbe probe_image(std::string_view bytes);

}  // namespace arscout::ingest
