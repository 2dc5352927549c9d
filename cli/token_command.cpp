// `arscout token create`: bearer tokens for scouts, planners and admins.
#include <iostream>

#include "arscout/ingest/auth.h"
#include "cli_support.h"
#include "command_registry.h"
#include "commands.h"

namespace arscout::cli {
namespace {

struct TokenArgs {
  std::string db;
  std::string role;
  std::string name;
};

void add_token_commands(CLI::App& app) {
  static TokenArgs args;
  CLI::App* token = app.add_subcommand("token", "manage API tokens");
  token->require_subcommand(1);
  CLI::App* create = token->add_subcommand(
      "create",
      "create a token and print it (once: only its SHA-256 is stored)");
  create->add_option("--db", args.db, "database URL")->required();
  create->add_option("--role", args.role, "scout | planner | admin")
      ->required()
      ->check(CLI::IsMember({"scout", "planner", "admin"}));
  create
      ->add_option("--name", args.name,
                   "who holds it; for a scout, its scout id")
      ->required();
  create->callback([] {
    run_command([] {
      auto store = db::Store::open(args.db);
      auto role = ingest::role_from_string(args.role);
      std::cout << ingest::create_token(*store, *role, args.name) << std::endl;
      return kExitOk;
    });
  });
}

const CommandRegistration registration(25, add_token_commands);

}  // namespace
}  // namespace arscout::cli
