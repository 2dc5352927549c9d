// `arscout token create`: bearer tokens for scouts, planners and admins,
// and for a scout the QR code that pairs a phone with the scout app.
#include <filesystem>
#include <iostream>
#include <regex>

#include "arscout/ingest/auth.h"
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
  std::string qr_url;
  std::string qr_png;
};

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
  const std::string token = ingest::create_token(*store, *role, a.name);
  std::cout << token << std::endl;
  return a.qr_url.empty() ? kExitOk : print_pairing(a, token);
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
  create_cmd->add_option(
      "--qr", args.qr_url,
      "scout app address (https://HOST:PORT/scout/): also print a QR code "
      "of it with the token, for the phone to scan (docs/scout-app.md)");
  create_cmd->add_option("--qr-png", args.qr_png,
                         "where --qr writes the code as PNG "
                         "(default scout-NAME-qr.png)");
  create_cmd->callback([] { run_command([] { return create(args); }); });
}

const CommandRegistration registration(25, add_token_commands);

}  // namespace
}  // namespace arscout::cli
