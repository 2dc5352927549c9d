// The decode budget for uploaded images: how much decoding one may cost,
// read from the image's own header, and the one gate every decode of an
// uploaded photo goes through (uploads, thumbnails, overlays).
#pragma once

#include <optional>
#include <string>
#include <string_view>

#include <opencv2/core.hpp>

#include "arscout/util/image_header.h"

namespace arscout::ingest {

// Refuses images whose header declares more than kMaxImagePixels, or whose
// decoded form would take more than kMaxDecodeBytes, before decoding them:
// a 1 KB JPEG can declare 30000 x 30000 pixels, a 1 MB PNG 119.9 MP of
// 16-bit RGBA (960 MB). Both are read from the image's own header (JPEG
// SOF, PNG IHDR), never from a metadata parser that might give up, and an
// image whose header cannot be read is refused (fail closed).
constexpr long kMaxImagePixels = 120'000'000;  // 108 MP phones fit
constexpr long long kMaxDecodeBytes = 3LL * kMaxImagePixels;  // 8-bit RGB
// What an image's header declares (util/image_header.h: JPEG SOF or PNG
// IHDR): size, channels after decoding with IMREAD_UNCHANGED, and bytes per
// channel; nullopt when it is neither, its header is malformed, or it does
// not say its channels.
using ImageHeader = util::ImageHeader;
std::optional<ImageHeader> read_image_header(std::string_view bytes);

// Why `bytes` may not be decoded ("" when it may): its header unreadable,
// over kMaxImagePixels or over kMaxDecodeBytes. For every decode of an
// uploaded image: uploads, thumbnails, overlays.
std::string decode_refusal(std::string_view bytes);

// cv::imdecode(bytes, flags) after decode_refusal() says yes, holding one
// of the decode slots (as many as cores, shared by every decode in the
// process); an empty Mat and `*why` set otherwise or when it fails.
cv::Mat decode_within_budget(std::string_view bytes, int flags,
                             std::string* why);

}  // namespace arscout::ingest
