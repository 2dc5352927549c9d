// Validates an uploaded image and reads its size, decoding it once.
#pragma once

#include <optional>
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

// Refuses images whose header declares more than kMaxImagePixels before
// decoding them: a 1 KB JPEG can declare 30000 x 30000 pixels, and decoding
// it would take gigabytes.
constexpr long kMaxImagePixels = 120'000'000;  // 108 MP phones fit
ImageProbe probe_image(std::string_view bytes);

// The width and height an image's header declares, read without decoding
// it (Exiv2; defined in exif.cpp with the rest of the Exiv2 use); nullopt
// when the header cannot be read.
struct DeclaredSize {
  long width = 0, height = 0;
};
std::optional<DeclaredSize> read_declared_size(std::string_view image_bytes);

}  // namespace arscout::ingest
