// The engine worker's command-line options, shared by `arscout engine` and
// `arscout serve --with-engine`.
#pragma once

#include "arscout/engine/service.h"
#include "arscout/ingest/server.h"

// Its users define their commands with CLI11 (command_registry.h) already.
namespace CLI {
class App;
}

namespace arscout::cli {

void add_engine_worker_options(CLI::App* cmd, engine::WorkerOptions* options);

// Logs each progress line on stderr, as the server logs ("time level=info
// event=engine msg=..."), at info: shown with --log-level info.
void log_worker_progress(engine::WorkerOptions* options);

// A server's /metrics then carries the worker's metrics, and its /healthz
// the worker's state as "engine" (docs/service.md, "Health and metrics").
// The worker must outlive the server.
void expose_worker(const engine::EngineWorker& worker,
                   ingest::ServerOptions* options);

// "HOST:PORT" or "[V6]:PORT"; false when it is neither.
bool split_listen(const std::string& text, std::string* host,
                  std::uint16_t* port);

}  // namespace arscout::cli
