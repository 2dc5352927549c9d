// SHA-256 as lower-case hex (OpenSSL), for tokens and upload idempotency.
#pragma once

#include <string>
#include <string_view>

namespace arscout::ingest {

std::string sha256_hex(std::string_view bytes);
std::string to_hex(const unsigned char* bytes, std::size_t n);

}  // namespace arscout::ingest
