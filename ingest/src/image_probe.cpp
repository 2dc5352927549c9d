#include "image_probe.h"

#include <algorithm>
#include <condition_variable>
#include <mutex>
#include <opencv2/imgcodecs.hpp>
#include <thread>

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

// Bounds concurrent decodes to the number of cores.
class DecodeSlot {
 public:
  DecodeSlot() {
    std::unique_lock lock(mu_);
    cv_.wait(lock, [] { return busy_ < limit(); });
    ++busy_;
  }
  ~DecodeSlot() {
    {
      std::lock_guard lock(mu_);
      --busy_;
    }
    cv_.notify_one();
  }

 private:
  static unsigned limit() {
    static const unsigned n = std::max(1u, std::thread::hardware_concurrency());
    return n;
  }
  static inline std::mutex mu_;
  static inline std::condition_variable cv_;
  static inline unsigned busy_ = 0;
};

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
  auto declared = read_declared_size(bytes);
  if (declared && declared->width * declared->height > kMaxImagePixels)
    return fail(p.format + " of " + std::to_string(declared->width) + " x " +
                std::to_string(declared->height) + " pixels: more than the " +
                std::to_string(kMaxImagePixels / 1'000'000) +
                " megapixels accepted");
  cv::Mat raw(1, static_cast<int>(bytes.size()), CV_8UC1,
              const_cast<char*>(bytes.data()));
  cv::Mat image;
  try {
    // A decode holds tens of MB and a core: more at once than there are
    // cores only adds memory and latency.
    DecodeSlot slot;
    image = cv::imdecode(raw, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    return fail("corrupt " + p.format + ": " + e.what());
  }
  if (image.empty())
    return fail("corrupt " + p.format + ": it does not decode");
  p.ok = true;
  p.width = image.cols;
  p.height = image.rows;
  return p;
}

}  // namespace arscout::ingest
