// `arscout engine`: a standalone engine worker (docs/service.md).
#include <chrono>
#include <iostream>
#include <sstream>
#include <thread>

#include <spdlog/spdlog.h>

#include "arscout/db/store.h"
#include "arscout/ingest/server.h"
#include "arscout/util/error.h"
#include "arscout/util/log_value.h"
#include "cli_support.h"
#include "command_registry.h"
#include "commands.h"
#include "engine_options.h"

namespace arscout::cli {
namespace {

// An option in seconds (fractions allowed) kept as milliseconds.
CLI::Option* add_seconds_option(CLI::App* cmd, const std::string& name,
                                std::chrono::milliseconds* kept,
                                const std::string& help) {
  return cmd->add_option_function<double>(
      name,
      [kept](double seconds) {
        *kept = std::chrono::milliseconds(
            static_cast<std::int64_t>(seconds * 1000));
      },
      help);
}

}  // namespace

void add_engine_worker_options(CLI::App* cmd, engine::WorkerOptions* o) {
  cmd->add_option("--engine-name", o->name,
                  "worker name: its feed checkpoint /checkpoints/NAME")
      ->capture_default_str();
  cmd->add_option("--site-radius", o->site_radius_m,
                  "metres: a capture joins the nearest site whose footprint "
                  "(centre and extent) comes this close, else founds one")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->add_option("--site-threads", o->site_threads,
                  "sites reconstructed at the same time")
      ->capture_default_str()
      ->check(CLI::Range(1, 64));
  add_seconds_option(cmd, "--lease-ttl", &o->lease_ttl,
                     "seconds a site lease lasts unrenewed: when a worker "
                     "dies, others take its sites over after this (renewed "
                     "every third; default 15)")
      ->check(CLI::Range(0.3, 3600.0));
  add_seconds_option(cmd, "--state-interval", &o->state_interval,
                     "seconds a site's engine state may stay unsaved while "
                     "photos keep coming (also saved after a quiet second; a "
                     "crash redoes what was unsaved; 0: at every increment; "
                     "default 30)")
      ->check(CLI::Range(0.0, 3600.0));
  o->refinement_interval = std::chrono::seconds(10);
  add_seconds_option(cmd, "--refine-interval", &o->refinement_interval,
                     "seconds: a site publishes a version of its global "
                     "refinement (one that adds no photo) at most this often; "
                     "a merge or a loop closure does not wait (0: no bound; "
                     "default 10)")
      ->check(CLI::Range(0.0, 3600.0));
  o->dense_tile_interval = std::chrono::seconds(30);
  add_seconds_option(cmd, "--dense-tile-interval", &o->dense_tile_interval,
                     "seconds: while a site's dense lane has work left over, "
                     "it stores its cloud's changed tiles at most this often "
                     "(the depth maps at every phase; the lane's last phase "
                     "always stores them; 0: every phase; default 30)")
      ->check(CLI::Range(0.0, 3600.0));
  cmd->add_option("--prepare-ahead", o->prepare_ahead,
                  "photos decoded and described ahead of their increments, "
                  "on a thread of their own, at most this many held (0: "
                  "each inside its increment)")
      ->capture_default_str()
      ->check(CLI::Range(0, 1000));
  cmd->add_option("--increment-captures", o->increment_captures,
                  "captures one increment of a site takes at most, in turns "
                  "between scouts; those queued behind wait for the next "
                  "(docs/service.md, \"One increment\")")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000));
  cmd->add_option("--max-features", o->reconstruction.max_features,
                  "Harris corners per photo; more make a long walk straighter "
                  "(docs/engine.md, \"How many corners\")")
      ->capture_default_str()
      ->check(CLI::Range(100, 50000));
  cmd->add_option("--match-features", o->reconstruction.match_features,
                  "of those, the strongest that a photo's increment matches "
                  "(its cost grows faster than this); the refinement matches "
                  "the rest along epipolar lines, off the latency path")
      ->capture_default_str()
      ->check(CLI::Range(100, 50000));
  cmd->add_flag("!--no-dense", o->dense, "sparse models only");
  cmd->add_flag("--mesh", o->mesh,
                "a textured surface per mesh tile, made in the dense lane "
                "where the points changed and published with the model "
                "(docs/mesh.md)");
  cmd->add_option("--mesh-budget", o->mesh_budget_seconds,
                  "seconds of mesh tile making per dense phase; the tiles in "
                  "most need first, the rest in later phases (0: every "
                  "changed tile each phase)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 3600.0));
  cmd->add_option("--dense-long-side", o->dense_options.long_side,
                  "dense working resolution, long side in px")
      ->capture_default_str()
      ->check(CLI::Range(100, 10000));
  cmd->add_option("--dense-new-coverage", o->dense_options.new_coverage_share,
                  "sweep no depth map for a photo when two held maps "
                  "already measure this share of its picture (0: off; 0.8 "
                  "halves the sweeps on a walk, thins converging photos' "
                  "clouds: docs/dense.md)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
  cmd->add_option("--dense-catch-up", o->dense_options.catch_up_backlog,
                  "when more photos than this wait for their depth map, "
                  "sweep with planes twice as far apart until the dense "
                  "lane has caught up (-1: the default, 2; 0: never)")
      ->capture_default_str()
      ->check(CLI::Range(-1, 1000));
  cmd->add_flag("--deterministic", o->reconstruction.deterministic,
                "fixed seeds, single-threaded solvers and one capture per "
                "increment: the same feed gives the same models");
}

void log_worker_progress(engine::WorkerOptions* options) {
  options->progress = [](const std::string& line) {
    spdlog::info("event=engine msg={}", util::quoted_log_value(line));
  };
}

void expose_worker(const engine::EngineWorker& worker,
                   ingest::ServerOptions* options) {
  options->extra_metrics = [&worker] { return worker.metrics(); };
  options->health_details = [&worker] {
    const engine::WorkerStats s = worker.stats();
    return ingest::Json{{"engine",
                         {{"captures_waiting", s.captures_waiting},
                          {"sites", s.sites},
                          {"sites_held", s.sites_held},
                          {"model_versions", s.increments},
                          {"failures", s.failures},
                          {"checkpoint", s.checkpoint}}}};
  };
}

void add_gc_options(CLI::App* cmd, db::BlobCollectorOptions* o) {
  cmd->add_option_function<long long>(
         "--gc-interval",
         [o](long long seconds) {
           o->interval = std::chrono::seconds(seconds);
         },
         "seconds between collections of blobs no document refers to "
         "(0: none; `arscout db gc` by hand; default 60)")
      ->check(CLI::Range(0LL, 86400LL));
  cmd->add_option_function<long long>(
         "--gc-min-age",
         [o](long long seconds) { o->min_age = std::chrono::seconds(seconds); },
         "seconds a new blob is kept unreferenced before it may be "
         "collected (at least twice --state-interval and a minute where an "
         "engine runs; default 300)")
      ->check(CLI::Range(60LL, 30LL * 86400));
}

void check_gc_grace(const db::BlobCollectorOptions& gc,
                    const engine::WorkerOptions& worker) {
  const auto needed = 2 * std::chrono::duration_cast<std::chrono::seconds>(
                              worker.state_interval) +
                      std::chrono::seconds(60);
  if (gc.interval.count() > 0 && gc.min_age < needed)
    throw util::Error(
        util::ErrorKind::kInvalidArgument,
        "--gc-min-age " + std::to_string(gc.min_age.count()) +
            " is too short for --state-interval " +
            (std::ostringstream() << worker.state_interval.count() / 1000.0)
                .str() +
            ": a capture's features wait for the next engine state to refer "
            "to them; give at least " +
            std::to_string(needed.count()) + " seconds");
}

void expose_collector(const db::BlobCollector& collector,
                      ingest::ServerOptions* options) {
  auto before = options->extra_metrics;
  options->extra_metrics = [before, &collector] {
    return (before ? before() : std::string()) + collector.metrics();
  };
}

bool split_listen(const std::string& text, std::string* host,
                  std::uint16_t* port) {
  std::size_t colon = text.rfind(':');
  if (colon == std::string::npos || colon == 0) return false;
  *host = text.substr(0, colon);
  if (host->front() == '[' && host->back() == ']')
    *host = host->substr(1, host->size() - 2);
  try {
    std::size_t used = 0;
    int p = std::stoi(text.substr(colon + 1), &used);
    if (used != text.size() - colon - 1 || p < 0 || p > 65535) return false;
    *port = static_cast<std::uint16_t>(p);
  } catch (const std::exception&) {
    return false;
  }
  return true;
}

namespace {

struct EngineArgs {
  std::string db;
  std::string listen;  // "": no endpoint
  engine::WorkerOptions worker;
  db::BlobCollectorOptions gc = default_gc_options();
};

// --listen: /healthz and /metrics only, no API (docs/service.md).
std::unique_ptr<ingest::Server> start_endpoint(
    const EngineArgs& a, db::Store& store, const engine::EngineWorker& worker,
    const db::BlobCollector& collector) {
  if (a.listen.empty()) return nullptr;
  ingest::ServerOptions options;
  if (!split_listen(a.listen, &options.host, &options.port))
    throw util::Error(util::ErrorKind::kInvalidArgument,
                      "--listen must be HOST:PORT, not '" + a.listen + "'");
  options.serve_api = false;
  options.worker_threads = 2;
  expose_worker(worker, &options);
  expose_collector(collector, &options);
  auto server = std::make_unique<ingest::Server>(store, options);
  server->start();
  std::cout << "engine health and metrics at http://" << options.host << ":"
            << server->port() << "/healthz and /metrics" << std::endl;
  return server;
}

int run_engine(EngineArgs& a) {
  check_gc_grace(a.gc, a.worker);
  install_stop_handlers();
  auto store = db::Store::open(a.db);
  log_worker_progress(&a.worker);
  engine::EngineWorker worker(*store, a.worker);
  db::BlobCollector collector(*store, a.gc);
  auto endpoint = start_endpoint(a, *store, worker, collector);
  worker.start();
  collector.start();
  while (!stop_requested())
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  if (endpoint) endpoint->stop();
  collector.stop();
  worker.stop();
  const engine::WorkerStats s = worker.stats();
  std::cout << "engine stopped: " << s.captures_placed << " captures placed, "
            << s.increments << " model versions, checkpoint " << s.checkpoint
            << std::endl;
  return kExitOk;
}

void add_engine_command(CLI::App& app) {
  static EngineArgs args;
  CLI::App* cmd = app.add_subcommand(
      "engine",
      "run an engine worker: follow /captures/*, reconstruct each site "
      "incrementally, write /sites/{id}/model back");
  cmd->add_option("--db", args.db,
                  "database URL: sqlite:FILE or postgresql://...")
      ->required();
  cmd->add_option("--listen", args.listen,
                  "HOST:PORT to serve /healthz and /metrics on (port 0: any; "
                  "no API there)");
  add_engine_worker_options(cmd, &args.worker);
  add_gc_options(cmd, &args.gc);
  cmd->callback([] { run_command([] { return run_engine(args); }); });
}

const CommandRegistration engine_command_registration(25, add_engine_command);

}  // namespace
}  // namespace arscout::cli
