// Exit codes of the arscout executable. Subcommand families register
// themselves (command_registry.h).
#pragma once

namespace arscout::cli {

// Exit codes shared by every subcommand (documented in docs/cli.md).
enum ExitCode : int {
  kExitOk = 0,
  kExitError = 1,       // any failure not listed below
  kExitUsage = 2,       // bad arguments or input
  kExitConflict = 3,    // a version conflict
  kExitNotFound = 4,    // no such document or blob
  kExitUnavailable = 5  // the database cannot be opened or reached
};

}  // namespace arscout::cli
