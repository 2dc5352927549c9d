// Helpers shared by subcommands: error-to-exit-code mapping, JSON parsing of
// arguments, and stopping on SIGINT/SIGTERM.
#pragma once

#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "arscout/db/document.h"

namespace arscout::cli {

// Runs a subcommand's body and records its exit code for main(); a
// db::StoreError, util::Error (through db::code_of) or other exception is
// printed to stderr as "arscout: error (kind): ..." and turned into its
// exit code.
void run_command(const std::function<int()>& body);
int last_exit_code();

// Parses text as JSON or throws util::Error(kInvalidJson) naming the
// position.
db::Json parse_json_argument(const std::string& text, const std::string& what);

// The image files (.jpg .jpeg .png .tif .tiff .bmp, any case) directly in
// `dir`, sorted by name so runs are reproducible. Throws
// util::Error(kInvalidArgument) when there are none.
std::vector<std::string> list_image_files(const std::string& dir);

// The bytes of a file named on the command line; util::Error
// (kInvalidArgument, exit code 2) naming it when it cannot be read.
std::string read_input_file(const std::string& path);

// Replaces the file at `path` with `bytes` atomically and durably
// (util::write_file_atomic): a reader never sees half a file, and a failed
// write leaves the older one intact. util::Error (kUnavailable, exit code 5)
// naming it when it cannot be written.
void write_output_file(const std::string& path, std::string_view bytes);

// Installs SIGINT/SIGTERM handlers; stop_requested() turns true after one.
void install_stop_handlers();
bool stop_requested();

}  // namespace arscout::cli
