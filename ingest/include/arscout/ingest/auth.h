// Bearer tokens. A token is shown once, at creation; the store keeps only
// its SHA-256, as the document /auth/tokens/{sha256} {"role", "name"}.
#pragma once

#include <optional>
#include <string>

#include "arscout/db/store.h"

namespace arscout::ingest {

enum class Role { kScout, kPlanner, kAdmin };

const char* to_string(Role role);
// "scout" | "planner" | "admin"; nullopt otherwise.
std::optional<Role> role_from_string(const std::string& text);

struct Principal {
  Role role;
  std::string name;  // for scouts, the scout id (/scouts/{name})
};

// Creates a token for `name` with `role` and returns it (the only time it is
// seen). For a scout also creates /scouts/{name} if it does not exist.
// Throws db::StoreError for an invalid name.
std::string create_token(db::Store& store, Role role, const std::string& name);

// The principal for an "Authorization" header value ("Bearer TOKEN"), or
// nullopt for a missing, malformed or unknown token.
std::optional<Principal> authenticate(db::Store& store,
                                      const std::string& authorization);

}  // namespace arscout::ingest
