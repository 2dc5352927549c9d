// Validates an uploaded image and reads its size, decoding it once.
#pragma once

#include <optional>
#include <string>
#include <string_view>

#include "arscout/ingest/image_budget.h"

namespace arscout::ingest {

struct ImageProbe {
  bool ok = false;
  std::string error;   // when !ok: what is wrong, e.g. "truncated JPEG"
  std::string format;  // "jpeg" | "png"
  int width = 0;
  int height = 0;
};

// Validated against the decode budget (arscout/ingest/image_budget.h).
ImageProbe probe_image(std::string_view bytes);

}  // namespace arscout::ingest
