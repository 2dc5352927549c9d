// The engine worker's command-line options, shared by `arscout engine` and
// `arscout serve --with-engine`.
#pragma once

#include "arscout/db/blob_collector.h"
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

// --gc-interval and --gc-min-age: the blob collector that `arscout serve`
// and `arscout engine` run (docs/service.md, "Storage").
void add_gc_options(CLI::App* cmd, db::BlobCollectorOptions* options);
// Their defaults: every 60 s, a grace of 300 s. The garbage waiting at any
// time is what the writers discard in about interval + grace, so both are
// short; the grace still covers every wait between a blob's store and its
// reference in this project (the longest: a capture's features, referenced
// by the next engine state, --state-interval).
inline db::BlobCollectorOptions default_gc_options() {
  return {std::chrono::seconds(60), std::chrono::seconds(300)};
}

// Throws util::Error(kInvalidArgument) when the collector runs and its grace
// is shorter than twice the worker's --state-interval plus a minute: the
// features the engine stores wait for the next state to refer to them.
void check_gc_grace(const db::BlobCollectorOptions& gc,
                    const engine::WorkerOptions& worker);

// A server's /metrics then also carries the collector's (arscout_gc_*,
// arscout_store_blob*). The collector must outlive the server.
void expose_collector(const db::BlobCollector& collector,
                      ingest::ServerOptions* options);

// "HOST:PORT" or "[V6]:PORT"; false when it is neither.
bool split_listen(const std::string& text, std::string* host,
                  std::uint16_t* port);

}  // namespace arscout::cli
