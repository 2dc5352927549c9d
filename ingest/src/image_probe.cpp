#include "image_probe.h"

#include <opencv2/imgcodecs.hpp>

namespace arscout::ingest {
namespace {

bool starts_with(std::string_view b, std::string_view magic) {
  return b.substr(0, magic.size()) == magic;
}

// libjpeg decodes a truncated file with a warning and grey fill, so the end
// marker is checked explicitly (trailing zero padding is tolerated).
bool jpeg_has_end_marker(std::string_view b) {
  std::size_t end = b.size();
  while (end > 2 && b[end - 1] == '\0') --end;
  return end >= 4 && static_cast<unsigned char>(b[end - 2]) == 0xFF &&
         static_cast<unsigned char>(b[end - 1]) == 0xD9;
}

bool png_has_end_chunk(std::string_view b) {
  return b.size() >= 12 &&
         b.substr(b.size() - 12, 8) == std::string_view("\0\0\0\0IEND", 8);
}

ImageProbe fail(std::string why) {
  ImageProbe p;
  p.error = std::move(why);
  return p;
}

}  // namespace

ImageProbe probe_image(std::string_view bytes) {
  if (bytes.empty())
    return fail("the body is empty; expected a JPEG or PNG image");
  ImageProbe p;
  if (starts_with(bytes, "\xFF\xD8\xFF")) {
    p.format = "jpeg";
    if (!jpeg_has_end_marker(bytes))
      return fail("truncated or corrupt JPEG: no end-of-image marker");
  } else if (starts_with(bytes, "\x89PNG\r\n\x1a\n")) {
    p.format = "png";
    if (!png_has_end_chunk(bytes))
      return fail("truncated or corrupt PNG: no IEND chunk at the end");
  } else {
    return fail("not a JPEG or PNG image (unrecognised file signature)");
  }
  std::string why;
  const cv::Mat image = decode_within_budget(bytes, cv::IMREAD_UNCHANGED, &why);
  if (image.empty()) return fail(why);
  p.ok = true;
  p.width = image.cols;
  p.height = image.rows;
  return p;
}

}  // namespace arscout::ingest
