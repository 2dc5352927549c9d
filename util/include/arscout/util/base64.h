// Base64 (RFC 4648, with padding) through OpenSSL: blobs in session files,
// digests in Content-Security-Policy headers.
#pragma once

#include <optional>
#include <string>
#include <string_view>

namespace arscout::util {

std::string to_base64(std::string_view bytes);
// nullopt when `text` is not padded Base64.
std::optional<std::string> from_base64(std::string_view text);
// The SHA-256 digest of `bytes` in Base64, as CSP source hashes name it
// ('sha256-...').
std::string sha256_base64(std::string_view bytes);

}  // namespace arscout::util
