// `arscout engine`: a standalone engine worker (docs/service.md).
#include <chrono>
#include <ctime>
#include <iomanip>
#include <iostream>
#include <mutex>
#include <thread>

#include "arscout/db/store.h"
#include "cli_support.h"
#include "command_registry.h"
#include "commands.h"
#include "engine_options.h"

namespace arscout::cli {

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
  cmd->add_option_function<double>(
         "--lease-ttl",
         [o](double seconds) {
           o->lease_ttl = std::chrono::milliseconds(
               static_cast<std::int64_t>(seconds * 1000));
         },
         "seconds a site lease lasts unrenewed: when a worker dies, others "
         "take its sites over after this (renewed every third; default 15)")
      ->check(CLI::Range(0.3, 3600.0));
  cmd->add_flag("!--no-dense", o->dense, "sparse models only");
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

void print_worker_progress(engine::WorkerOptions* options) {
  static std::mutex mutex;
  options->progress = [](const std::string& line) {
    const std::time_t now = std::time(nullptr);
    std::lock_guard lock(mutex);
    std::cout << std::put_time(std::localtime(&now), "%H:%M:%S") << " " << line
              << std::endl;
  };
}

namespace {

struct EngineArgs {
  std::string db;
  engine::WorkerOptions worker;
};

int run_engine(EngineArgs& a) {
  install_stop_handlers();
  auto store = db::Store::open(a.db);
  print_worker_progress(&a.worker);
  engine::EngineWorker worker(*store, a.worker);
  worker.start();
  while (!stop_requested())
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
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
  add_engine_worker_options(cmd, &args.worker);
  cmd->callback([] { run_command([] { return run_engine(args); }); });
}

const CommandRegistration registration(25, add_engine_command);

}  // namespace
}  // namespace arscout::cli
