// SHA-256 digests as lower-case hex (OpenSSL's EVP): blob names, token
// hashes, upload idempotency keys.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

struct evp_md_ctx_st;

namespace arscout::util {

// Incremental: update() any number of times, then hex_digest() once.
// Throws std::runtime_error when OpenSSL fails (out of memory).
class Sha256 {
 public:
  Sha256();
  ~Sha256();
  Sha256(const Sha256&) = delete;
  Sha256& operator=(const Sha256&) = delete;

  void update(std::string_view bytes);
  // The digest of everything updated so far; the object is then spent.
  std::string hex_digest();

 private:
  evp_md_ctx_st* ctx_;
};

std::string sha256_hex(std::string_view bytes);

// True for 64 lower-case hex digits (what sha256_hex returns).
bool is_sha256_hex(std::string_view text);

// Lower-case hex of `n` bytes: two digits a byte.
std::string to_hex(const unsigned char* bytes, std::size_t n);

}  // namespace arscout::util
