// Incremental SHA-256 (OpenSSL EVP) producing lower-case hex digests.
#pragma once

#include <memory>
#include <string>
#include <string_view>

struct evp_md_ctx_st;

namespace arscout::db::internal {

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
// True for 64 lower-case hex digits.
bool is_sha256_hex(std::string_view text);

}  // namespace arscout::db::internal
