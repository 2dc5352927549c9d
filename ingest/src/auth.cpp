#include "arscout/ingest/auth.h"
#include "arscout/util/error.h"

#include <openssl/rand.h>

#include <algorithm>
#include <ctime>

#include "arscout/db/path.h"
#include "arscout/util/sha256.h"
#include "arscout/util/time.h"

namespace arscout::ingest {
namespace {

constexpr const char* kTokens = "/auth/tokens";

std::string token_path(const std::string& token) {
  return std::string(kTokens) + "/" + util::sha256_hex(token);
}

std::int64_t now_s() { return static_cast<std::int64_t>(std::time(nullptr)); }

TokenInfo token_info(const db::Document& doc) {
  TokenInfo t;
  t.id = doc.path.substr(doc.path.rfind('/') + 1);
  t.role =
      role_from_string(doc.attrs.value("role", "")).value_or(Role::kPlanner);
  t.name = doc.attrs.value("name", "");
  t.created = doc.attrs.value("created", "");
  t.expires = doc.attrs.value("expires", "");
  t.revoked = doc.attrs.value("revoked", "");
  return t;
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

std::string TokenInfo::state(std::int64_t at_s) const {
  if (!revoked.empty()) return "revoked";
  if (!expires.empty()) {
    const auto end = util::parse_time_utc(expires);
    if (!end || *end <= at_s) return "expired";
  }
  return "active";
}

std::string token_name_problem(const std::string& name) {
  if (name.empty()) return "a token name is not empty";
  if (name.find('/') != std::string::npos)
    return "a token name is one path segment, not '" + name + "'";
  if (name.find('.') != std::string::npos)  // capture ids are "{name}.{id}"
    return "a token name holds no '.' (letters, digits, '_' and '-'), not '" +
           name + "'";
  try {
    db::validate_path("/" + name);  // names become path segments
  } catch (const db::StoreError& e) {
    return std::string("a token name is a path segment: ") + e.what();
  }
  return "";
}

std::string create_token(db::Store& store, Role role, const std::string& name,
                         std::optional<std::int64_t> expires_s) {
  if (expires_s && *expires_s <= now_s())
    throw util::Error(util::ErrorKind::kInvalidArgument,
                      "the expiry " + util::format_time_utc(*expires_s) +
                          " is not in the future");
  if (std::string problem = token_name_problem(name); !problem.empty())
    throw util::Error(util::ErrorKind::kInvalidArgument, problem);
  unsigned char random[32];
  if (RAND_bytes(random, sizeof random) != 1)
    throw util::Error(util::ErrorKind::kInternal,
                      "no randomness for a token (RAND_bytes failed)");
  std::string token = "ars_" + util::to_hex(random, sizeof random);
  db::Json attrs{{"role", to_string(role)},
                 {"name", name},
                 {"created", util::format_time_utc(now_s())}};
  if (expires_s) attrs["expires"] = util::format_time_utc(*expires_s);
  std::vector<db::WriteOp> ops = {
      db::WriteOp::put(token_path(token), "token", attrs, 0)};
  if (role == Role::kScout && !store.get("/scouts/" + name))
    ops.push_back(db::WriteOp::put("/scouts/" + name, "scout",
                                   db::Json{{"name", name}, {"role", "scout"}},
                                   0));
  store.batch(ops);
  return token;
}

const char* to_string(AuthFailure failure) {
  switch (failure) {
    case AuthFailure::kMissing:
      return "missing";
    case AuthFailure::kMalformed:
      return "malformed";
    case AuthFailure::kUnknown:
      return "unknown";
    case AuthFailure::kRevoked:
      return "revoked";
    case AuthFailure::kExpired:
      return "expired";
  }
  return "unknown";
}

std::variant<Principal, AuthFailure> check_token(
    db::Store& store, const std::string& authorization) {
  static const std::string kPrefix = "Bearer ";
  if (authorization.empty()) return AuthFailure::kMissing;
  if (authorization.compare(0, kPrefix.size(), kPrefix) != 0)
    return AuthFailure::kMalformed;
  std::string token = authorization.substr(kPrefix.size());
  if (token.empty() || token.size() > 200) return AuthFailure::kMalformed;
  auto doc = store.get(token_path(token));
  if (!doc) return AuthFailure::kUnknown;
  auto role = role_from_string(doc->attrs.value("role", ""));
  if (!role) return AuthFailure::kUnknown;
  const TokenInfo info = token_info(*doc);
  const std::string state = info.state(now_s());
  if (state == "revoked") return AuthFailure::kRevoked;
  if (state == "expired") return AuthFailure::kExpired;
  return Principal{*role, info.name, info.expires};
}

std::optional<Principal> authenticate(db::Store& store,
                                      const std::string& authorization) {
  auto checked = check_token(store, authorization);
  if (auto* who = std::get_if<Principal>(&checked)) return *who;
  return std::nullopt;
}

std::vector<TokenInfo> list_tokens(db::Store& store) {
  std::vector<TokenInfo> out;
  for (const db::Document& doc : store.list_children(kTokens))
    out.push_back(token_info(doc));
  std::stable_sort(out.begin(), out.end(), [](const auto& a, const auto& b) {
    return a.created < b.created;
  });
  return out;
}

std::vector<TokenInfo> revoke_tokens(db::Store& store,
                                     const std::string& id_prefix,
                                     const std::string& name) {
  if (!id_prefix.empty() && id_prefix.size() < 8)
    throw util::Error(util::ErrorKind::kInvalidArgument,
                      "a token id needs at least 8 hex digits");
  std::vector<TokenInfo> chosen;
  for (const TokenInfo& t : list_tokens(store)) {
    const bool match = id_prefix.empty()
                           ? t.name == name
                           : t.id.compare(0, id_prefix.size(), id_prefix) == 0;
    if (match) chosen.push_back(t);
  }
  if (chosen.empty())  // nothing to revoke: "no such", as docs/cli.md says
    throw util::Error(
        util::ErrorKind::kNotFound,
        "no token matches " +
            (id_prefix.empty() ? "the name " + name : "the id " + id_prefix));
  if (!id_prefix.empty() && chosen.size() > 1)
    throw util::Error(util::ErrorKind::kInvalidArgument,
                      "the id " + id_prefix + " matches " +
                          std::to_string(chosen.size()) +
                          " tokens: give more digits");
  std::vector<TokenInfo> revoked;
  const std::string when = util::format_time_utc(now_s());
  for (TokenInfo& t : chosen) {
    if (!t.revoked.empty()) continue;
    store.patch(std::string(kTokens) + "/" + t.id, db::Json{{"revoked", when}});
    t.revoked = when;
    revoked.push_back(t);
  }
  return revoked;
}

}  // namespace arscout::ingest
