#include "arscout/ingest/image_budget.h"

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

unsigned be16(std::string_view b, std::size_t at) {
  return (static_cast<unsigned char>(b[at]) << 8) |
         static_cast<unsigned char>(b[at + 1]);
}

unsigned long be32(std::string_view b, std::size_t at) {
  return (static_cast<unsigned long>(be16(b, at)) << 16) | be16(b, at + 2);
}

// PNG: the IHDR chunk comes first (width, height, bit depth, colour type).
std::optional<ImageHeader> png_header(std::string_view b) {
  if (b.size() < 33 || b.substr(12, 4) != "IHDR") return std::nullopt;
  ImageHeader h;
  h.width = static_cast<long>(be32(b, 16));
  h.height = static_cast<long>(be32(b, 20));
  const int depth = static_cast<unsigned char>(b[24]);
  switch (static_cast<unsigned char>(b[25])) {
    case 0:
      h.channels = 1;
      break;  // grey
    case 2:
      h.channels = 3;
      break;  // RGB
    case 3:
      h.channels = 3;
      break;  // palette, decoded to BGR
    case 4:
      h.channels = 2;
      break;  // grey + alpha
    case 6:
      h.channels = 4;
      break;  // RGBA
    default:
      return std::nullopt;
  }
  h.bytes_per_channel = depth == 16 ? 2 : 1;
  return h;
}

// JPEG: walk the segments to the first start-of-frame marker.
std::optional<ImageHeader> jpeg_header(std::string_view b) {
  std::size_t at = 2;
  while (at + 4 <= b.size()) {
    if (static_cast<unsigned char>(b[at]) != 0xFF) return std::nullopt;
    const unsigned marker = static_cast<unsigned char>(b[at + 1]);
    if (marker == 0xFF) {  // fill byte
      ++at;
      continue;
    }
    const unsigned length = be16(b, at + 2);
    const bool sof = marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 &&
                     marker != 0xC8 && marker != 0xCC;
    if (sof) {
      if (at + 10 > b.size()) return std::nullopt;
      ImageHeader h;
      h.bytes_per_channel = static_cast<unsigned char>(b[at + 4]) > 8 ? 2 : 1;
      h.height = static_cast<long>(be16(b, at + 5));
      h.width = static_cast<long>(be16(b, at + 7));
      h.channels = static_cast<unsigned char>(b[at + 9]);
      return h;
    }
    if (marker == 0xDA || length < 2) return std::nullopt;  // scan before SOF
    at += 2 + length;
  }
  return std::nullopt;
}

}  // namespace

std::optional<ImageHeader> read_image_header(std::string_view bytes) {
  std::optional<ImageHeader> h;
  if (starts_with(bytes, "\xFF\xD8\xFF")) h = jpeg_header(bytes);
  if (starts_with(bytes, "\x89PNG\r\n\x1a\n")) h = png_header(bytes);
  if (h && (h->width <= 0 || h->height <= 0 || h->channels <= 0))
    return std::nullopt;
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
