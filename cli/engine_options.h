// The engine worker's command-line options, shared by `arscout engine` and
// `arscout serve --with-engine`.
#pragma once

#include <CLI/CLI.hpp>

#include "arscout/engine/service.h"

namespace arscout::cli {

void add_engine_worker_options(CLI::App* cmd, engine::WorkerOptions* options);

// Prints each progress line to stdout with a timestamp.
void print_worker_progress(engine::WorkerOptions* options);

}  // namespace arscout::cli
