// What an encoded photo's own header declares (JPEG SOF segment, PNG IHDR
// chunk), read without decoding it: the one probe behind the engine's
// image sizes and the upload decode budget.
#pragma once

#include <optional>
#include <string_view>

namespace arscout::util {

struct ImageHeader {
  long width = 0, height = 0;
  // Channels after decoding everything (OpenCV's IMREAD_UNCHANGED) and
  // bytes per channel; channels is 0 when the header is too short to say
  // or names an unknown PNG colour type.
  int channels = 0;
  int bytes_per_channel = 1;
  long long decoded_bytes() const {
    return static_cast<long long>(width) * height * channels *
           bytes_per_channel;
  }
};

// The header of a JPEG or PNG: nullopt for other bytes, a malformed or
// truncated header (the size not there yet), a zero size or one over 2^30.
// A JPEG's segments are walked to the first start-of-frame; a scan before
// it ends the walk. Never reads past the end of `bytes`.
std::optional<ImageHeader> read_image_header(std::string_view bytes);

}  // namespace arscout::util
