// Lossless compression for the stored binary formats (features, depth
// maps): zlib's deflate, and a byte shuffle that makes arrays of numbers
// compress (the bytes of equal significance side by side: the high bytes of
// smooth floats repeat, the low ones do not).
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace arscout::util {

// `bytes` deflated (zlib's format, RFC 1950) at `level` 1 (fastest) to 9.
// Throws std::runtime_error only when zlib fails (out of memory).
std::string deflate_bytes(std::string_view bytes, int level = 1);

// The inverse of deflate_bytes for a stream known to hold exactly `size`
// bytes: throws std::runtime_error when `deflated` is damaged, truncated,
// followed by more bytes, or inflates to any other size (never more than
// `size` is allocated, so a stream cannot inflate without bound).
std::string inflate_bytes(std::string_view deflated, std::size_t size);

// The bytes of `count` numbers of `width` bytes each, regrouped: first
// byte 0 of every number, then byte 1 of every number, and so on. The
// size of `bytes` must be count * width (std::invalid_argument otherwise).
std::string shuffle_bytes(std::string_view bytes, std::size_t width);
// The inverse of shuffle_bytes.
std::string unshuffle_bytes(std::string_view bytes, std::size_t width);

}  // namespace arscout::util
