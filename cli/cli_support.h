// Helpers shared by subcommands: error-to-exit-code mapping, JSON parsing of
// arguments, and stopping on SIGINT/SIGTERM.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "arscout/db/document.h"

namespace arscout::cli {

// Runs a subcommand's body and records its exit code for main(); a
// StoreError or other exception is printed to stderr as
// "arscout: error (kind): ..." and turned into its exit code.
void run_command(const std::function<int()>& body);
int last_exit_code();

// Parses text as JSON or throws StoreError(kInvalidJson) naming the position.
db::Json parse_json_argument(const std::string& text, const std::string& what);

// The image files (.jpg .jpeg .png .tif .tiff .bmp, any case) directly in
// `dir`, sorted by name so runs are reproducible. Throws
// StoreError(kInvalidArgument) when there are none.
std::vector<std::string> list_image_files(const std::string& dir);

// Installs SIGINT/SIGTERM handlers; stop_requested() turns true after one.
void install_stop_handlers();
bool stop_requested();

}  // namespace arscout::cli
