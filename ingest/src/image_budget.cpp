#include "arscout/ingest/image_budget.h"

#include <algorithm>
#include <condition_variable>
#include <mutex>
#include <opencv2/imgcodecs.hpp>
#include <thread>

#include "arscout/util/image_header.h"

namespace arscout::ingest {
namespace {

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

}  // namespace

std::optional<ImageHeader> read_image_header(std::string_view bytes) {
  auto h = util::read_image_header(bytes);
  if (h && h->channels <= 0) return std::nullopt;  // the budget needs them
  return h;
}

std::string decode_refusal(std::string_view bytes) {
  const auto h = read_image_header(bytes);
  if (!h) return "unreadable image header: not decoded";
  const std::string size =
      std::to_string(h->width) + " x " + std::to_string(h->height);
  if (h->width * h->height > kMaxImagePixels)
    return "an image of " + size + " pixels: more than the " +
           std::to_string(kMaxImagePixels / 1'000'000) + " megapixels accepted";
  if (h->decoded_bytes() > kMaxDecodeBytes)
    return "an image of " + size + " pixels, " + std::to_string(h->channels) +
           " channels of " + std::to_string(8 * h->bytes_per_channel) +
           " bits: " + std::to_string(h->decoded_bytes() >> 20) +
           " MiB decoded, more than the " +
           std::to_string(kMaxDecodeBytes >> 20) + " MiB accepted";
  return "";
}

cv::Mat decode_within_budget(std::string_view bytes, int flags,
                             std::string* why) {
  *why = decode_refusal(bytes);
  if (!why->empty()) return cv::Mat();
  cv::Mat raw(1, static_cast<int>(bytes.size()), CV_8UC1,
              const_cast<char*>(bytes.data()));
  cv::Mat image;
  try {
    // A decode holds tens of MB and a core: more at once than there are
    // cores only adds memory and latency.
    DecodeSlot slot;
    image = cv::imdecode(raw, flags);
  } catch (const cv::Exception& e) {
    *why = std::string("corrupt image: ") + e.what();
    return cv::Mat();
  }
  if (image.empty()) *why = "corrupt image: it does not decode";
  return image;
}

}  // namespace arscout::ingest
