// Bearer tokens. A token is shown once, at creation; the store keeps only
// its SHA-256, as the document /auth/tokens/{sha256} {"role", "name",
// "created", and "expires" and "revoked" where set}. A revoked token's
// document stays (who held it, and when it ended).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "arscout/db/store.h"

namespace arscout::ingest {

enum class Role { kScout, kPlanner, kAdmin };

const char* to_string(Role role);
// "scout" | "planner" | "admin"; nullopt otherwise.
std::optional<Role> role_from_string(const std::string& text);

struct Principal {
  Role role;
  std::string name;          // for scouts, the scout id (/scouts/{name})
  std::string expires = "";  // RFC 3339 UTC, or "" for a token that never does
};

// Why a request's token was refused (GET /v1/me and every 401 name it, so
// that a client can tell its user what to do).
enum class AuthFailure {
  kMissing,    // no Authorization header
  kMalformed,  // not "Bearer " and a token of at most 200 characters
  kUnknown,    // no such token (or its document is not a token's)
  kRevoked,
  kExpired,
};
// "missing", "malformed", "unknown", "revoked", "expired".
const char* to_string(AuthFailure failure);

// Why `name` cannot name a token (and so a scout), or "": it must be one
// non-empty path segment without '.' (capture and camera ids are
// "{name}.{id}").
std::string token_name_problem(const std::string& name);

// Creates a token for `name` with `role` and returns it (the only time it is
// seen). For a scout also creates /scouts/{name} if it does not exist.
// With `expires_s` (seconds since the Unix epoch, UTC) the token stops
// working then. Throws util::Error for an invalid name or an expiry in
// the past.
std::string create_token(db::Store& store, Role role, const std::string& name,
                         std::optional<std::int64_t> expires_s = std::nullopt);

// The principal for an "Authorization" header value ("Bearer TOKEN"), or
// why there is none. It reads the store on every call, so a revocation or
// expiry holds at once on every server sharing the database.
std::variant<Principal, AuthFailure> check_token(
    db::Store& store, const std::string& authorization);
// check_token's principal, or nullopt.
std::optional<Principal> authenticate(db::Store& store,
                                      const std::string& authorization);

// A stored token, as `arscout token list` shows it: never the token
// itself, which is not kept.
struct TokenInfo {
  std::string id;  // the SHA-256 of the token, hex (its document's name)
  Role role = Role::kPlanner;
  std::string name;
  std::string created;  // RFC 3339 UTC
  std::string expires;  // RFC 3339 UTC, or "" for never
  std::string revoked;  // RFC 3339 UTC, or "" while not revoked
  // "active", "revoked" or "expired" at `at_s`.
  std::string state(std::int64_t at_s) const;
};

// Every token, revoked and expired ones included, oldest first.
std::vector<TokenInfo> list_tokens(db::Store& store);

// Revokes the tokens whose id starts with `id_prefix` (at least 8 hex
// digits, and it must name exactly one token) or, with an empty prefix,
// every token of `name`. Returns the tokens revoked now (already revoked
// ones are left as they are). Throws util::Error: kInvalidArgument when
// the selection is ambiguous or the prefix too short, kNotFound when it
// matches nothing.
std::vector<TokenInfo> revoke_tokens(db::Store& store,
                                     const std::string& id_prefix,
                                     const std::string& name);

}  // namespace arscout::ingest
