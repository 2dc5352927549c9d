// `arscout token create | list | revoke`: bearer tokens for scouts,
// planners and admins, their expiry and revocation, and for a scout the QR
// code that pairs a phone with the scout app.
#include <ctime>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <regex>

#include "arscout/ingest/auth.h"
#include "arscout/metadata/gps.h"
#include "arscout/util/error.h"
#include "cli_support.h"
#include "command_registry.h"
#include "commands.h"
#include "qr_code.h"

namespace arscout::cli {
namespace {

struct TokenArgs {
  std::string db;
  std::string role;
  std::string name;
  std::string expires;
  std::string qr_url;
  std::string qr_png;
  std::string id;  // revoke: a prefix of the token's id
  bool json = false;
};

// "--expires": a duration from now ("90m", "12h", "30d") or an RFC 3339
// time; nullopt when none was given. Throws util::Error when unreadable.
std::optional<std::int64_t> expiry(const std::string& text) {
  if (text.empty()) return std::nullopt;
  std::smatch m;
  if (std::regex_match(text, m, std::regex(R"((\d{1,6})([mhd]))"))) {
    const std::int64_t unit = m[2] == "m" ? 60 : m[2] == "h" ? 3600 : 86400;
    return static_cast<std::int64_t>(std::time(nullptr)) +
           std::stoll(m[1]) * unit;
  }
  if (auto t = metadata::parse_time_utc(text)) return t;
  throw util::Error(util::ErrorKind::kInvalidArgument,
                    "--expires takes a duration (90m, 12h, 30d) or an "
                    "RFC 3339 time, not '" +
                        text + "'");
}

// Why `--qr URL` cannot pair a phone, or "" when it can.
std::string qr_problem(const TokenArgs& a) {
  if (a.role != "scout")
    return "--qr pairs the scout app: it needs --role scout";
  if (!std::regex_match(a.qr_url, std::regex(R"(https?://[^\s#]+)"))) {
    return "--qr needs the scout app's address, http(s)://HOST:PORT/scout/, "
           "without a '#' (the token goes there)";
  }
  return "";
}

// The PNG's default name: the scout's, kept to characters safe in a file name.
std::string default_png(const std::string& name) {
  return "scout-" +
         std::regex_replace(name, std::regex("[^A-Za-z0-9._-]"), "_") +
         "-qr.png";
}

int print_pairing(const TokenArgs& a, const std::string& token) {
  const std::string address = a.qr_url + "#token=" + token;
  const QrCode code = encode_qr(address);
  const std::string png = a.qr_png.empty() ? default_png(a.name) : a.qr_png;
  write_qr_png(code, png);
  std::cout << qr_for_terminal(code) << "Scan with the phone's camera to open "
            << a.qr_url << " signed in as " << a.name << ".\nQR code also in "
            << png << " (it holds the token: keep it private)." << std::endl;
  return kExitOk;
}

int create(const TokenArgs& a) {
  if (!a.qr_url.empty()) {
    if (std::string problem = qr_problem(a); !problem.empty()) {
      std::cerr << "arscout token create: " << problem << std::endl;
      return kExitUsage;
    }
  }
  auto store = db::Store::open(a.db);
  auto role = ingest::role_from_string(a.role);
  const std::string token =
      ingest::create_token(*store, *role, a.name, expiry(a.expires));
  std::cout << token << std::endl;
  return a.qr_url.empty() ? kExitOk : print_pairing(a, token);
}

void print_tokens(const std::vector<ingest::TokenInfo>& tokens, bool json) {
  const std::int64_t now = static_cast<std::int64_t>(std::time(nullptr));
  if (!json)
    std::cout << "id            role     state    created               "
                 "expires               name\n";
  for (const ingest::TokenInfo& t : tokens) {
    if (json) {
      std::cout << db::Json{{"id", t.id},           {"role", to_string(t.role)},
                            {"name", t.name},       {"state", t.state(now)},
                            {"created", t.created}, {"expires", t.expires},
                            {"revoked", t.revoked}}
                       .dump()
                << "\n";
      continue;
    }
    std::cout << t.id.substr(0, 12) << "  " << std::left << std::setw(8)
              << to_string(t.role) << " " << std::setw(8) << t.state(now) << " "
              << std::setw(21) << t.created << " " << std::setw(21)
              << (t.expires.empty() ? "never" : t.expires) << " " << t.name
              << "\n";
  }
  std::cout << std::flush;
}

int revoke(const TokenArgs& a) {
  if (a.id.empty() == a.name.empty()) {
    std::cerr << "arscout token revoke: give --id PREFIX or --name N"
              << std::endl;
    return kExitUsage;
  }
  auto store = db::Store::open(a.db);
  const auto revoked = ingest::revoke_tokens(*store, a.id, a.name);
  for (const ingest::TokenInfo& t : revoked)
    std::cout << "revoked " << t.id.substr(0, 12) << " (" << to_string(t.role)
              << " " << t.name << ")\n";
  if (revoked.empty()) std::cout << "already revoked\n";
  std::cout << std::flush;
  return kExitOk;
}

void add_list_and_revoke(CLI::App* token, TokenArgs& args) {
  CLI::App* list = token->add_subcommand(
      "list", "list the tokens (id prefix, role, state, dates, holder)");
  list->add_option("--db", args.db, "database URL")->required();
  list->add_flag("--json", args.json, "one JSON object per line");
  list->callback([&args] {
    run_command([&args] {
      print_tokens(ingest::list_tokens(*db::Store::open(args.db)), args.json);
      return kExitOk;
    });
  });
  CLI::App* revoke_cmd = token->add_subcommand(
      "revoke",
      "revoke a token (by id prefix) or all of a holder's: refused at once "
      "by every server on the database, open change streams closed");
  revoke_cmd->add_option("--db", args.db, "database URL")->required();
  revoke_cmd->add_option("--id", args.id,
                         "the token's id or its first 8+ hex digits "
                         "(token list)");
  revoke_cmd->add_option("--name", args.name, "every token of this holder");
  revoke_cmd->callback(
      [&args] { run_command([&args] { return revoke(args); }); });
}

void add_token_commands(CLI::App& app) {
  static TokenArgs args;
  CLI::App* token = app.add_subcommand("token", "manage API tokens");
  token->require_subcommand(1);
  CLI::App* create_cmd = token->add_subcommand(
      "create",
      "create a token and print it (once: only its SHA-256 is stored)");
  create_cmd->add_option("--db", args.db, "database URL")->required();
  create_cmd->add_option("--role", args.role, "scout | planner | admin")
      ->required()
      ->check(CLI::IsMember({"scout", "planner", "admin"}));
  create_cmd
      ->add_option("--name", args.name,
                   "who holds it; for a scout, its scout id")
      ->required();
  create_cmd->add_option("--expires", args.expires,
                         "the token stops working after this: a duration "
                         "(90m, 12h, 30d) or an RFC 3339 time");
  create_cmd->add_option(
      "--qr", args.qr_url,
      "scout app address (https://HOST:PORT/scout/): also print a QR code "
      "of it with the token, for the phone to scan (docs/scout-app.md)");
  create_cmd->add_option("--qr-png", args.qr_png,
                         "where --qr writes the code as PNG "
                         "(default scout-NAME-qr.png)");
  create_cmd->callback([] { run_command([] { return create(args); }); });
  add_list_and_revoke(token, args);
}

const CommandRegistration token_commands_registration(25, add_token_commands);

}  // namespace
}  // namespace arscout::cli
