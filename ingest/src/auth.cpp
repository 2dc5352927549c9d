#include "arscout/ingest/auth.h"

#include <openssl/rand.h>

#include "arscout/db/path.h"
#include "digest.h"

namespace arscout::ingest {
namespace {

std::string token_path(const std::string& token) {
  return "/auth/tokens/" + sha256_hex(token);
}

}  // namespace

const char* to_string(Role role) {
  switch (role) {
    case Role::kScout:
      return "scout";
    case Role::kPlanner:
      return "planner";
    case Role::kAdmin:
      return "admin";
  }
  return "planner";
}

std::optional<Role> role_from_string(const std::string& text) {
  if (text == "scout") return Role::kScout;
  if (text == "planner") return Role::kPlanner;
  if (text == "admin") return Role::kAdmin;
  return std::nullopt;
}

std::string create_token(db::Store& store, Role role, const std::string& name) {
  db::validate_path("/" + name);  // names become path segments
  if (name.find('/') != std::string::npos)
    throw db::StoreError(
        db::ErrorCode::kInvalidArgument,
        "a token name is one path segment, not '" + name + "'");
  unsigned char random[32];
  if (RAND_bytes(random, sizeof random) != 1)
    throw db::StoreError(db::ErrorCode::kInternal,
                         "no randomness for a token (RAND_bytes failed)");
  std::string token = "ars_" + to_hex(random, sizeof random);
  std::vector<db::WriteOp> ops = {
      db::WriteOp::put(token_path(token), "token",
                       db::Json{{"role", to_string(role)}, {"name", name}}, 0)};
  if (role == Role::kScout && !store.get("/scouts/" + name))
    ops.push_back(db::WriteOp::put("/scouts/" + name, "scout",
                                   db::Json{{"name", name}, {"role", "scout"}},
                                   0));
  store.batch(ops);
  return token;
}

std::optional<Principal> authenticate(db::Store& store,
                                      const std::string& authorization) {
  static const std::string kPrefix = "Bearer ";
  if (authorization.compare(0, kPrefix.size(), kPrefix) != 0)
    return std::nullopt;
  std::string token = authorization.substr(kPrefix.size());
  if (token.empty() || token.size() > 200) return std::nullopt;
  auto doc = store.get(token_path(token));
  if (!doc) return std::nullopt;
  auto role = role_from_string(doc->attrs.value("role", ""));
  if (!role) return std::nullopt;
  return Principal{*role, doc->attrs.value("name", "")};
}

}  // namespace arscout::ingest
