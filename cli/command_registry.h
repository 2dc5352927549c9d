// Subcommand families register themselves, so adding one is adding a file:
//
//   namespace {
//   const CommandRegistration scout_commands_registration(30,
//   add_scout_commands);
//   }
//
// The registration's name is unique across files: the CLI is a unity build
// (cli/CMakeLists.txt), where every file's anonymous namespace is shared
// with the others of its batch.
//
// main() adds them in `order` (then name) so --help lists them stably.
#pragma once

// All of CLI11, though CommandAdder needs only CLI::App's name: every file
// that includes this defines commands with it.
#include <CLI/CLI.hpp>

namespace arscout::cli {

using CommandAdder = void (*)(CLI::App& app);

struct CommandRegistration {
  CommandRegistration(int order, CommandAdder adder);
};

// Calls every registered adder on app.
void add_registered_commands(CLI::App& app);

}  // namespace arscout::cli
