// `arscout session export` and `arscout session replay`: recorded scouting
// sessions (docs/sessions.md).
#include <filesystem>
#include <fstream>
#include <iostream>

#include "arscout/db/errors.h"
#include "arscout/ingest/session.h"
#include "arscout/util/error.h"
#include "cli_support.h"
#include "command_registry.h"
#include "commands.h"

namespace arscout::cli {
namespace {

namespace fs = std::filesystem;
using db::StoreError;

struct SessionExportArgs {
  std::string db;
  std::int64_t since = 0;
  std::string output;
};

struct ReplayArgs {
  std::string file;
  std::string db;
  double speed = 1;
  bool fast = false;
};

int run_session_export(const SessionExportArgs& a) {
  auto store = db::Store::open(a.db);
  const std::string part = a.output + ".part";
  ingest::SessionSummary summary;
  {
    std::ofstream out(part, std::ios::binary | std::ios::trunc);
    if (!out)
      throw util::Error(util::ErrorKind::kUnavailable, part + ": cannot write");
    std::int64_t shown = 0;
    summary = ingest::export_session(
        *store, a.since, out, [&](const ingest::SessionSummary& s) {
          if (s.changes - shown >= 1000) {
            shown = s.changes;
            std::cerr << "  " << s.changes << " changes, " << s.blobs
                      << " blobs (" << s.blob_bytes << " B) so far\n";
          }
        });
    out.flush();
    if (!out) {
      fs::remove(part);
      throw util::Error(util::ErrorKind::kUnavailable, part + ": cannot write");
    }
  }
  fs::rename(part, a.output);
  std::cout << "session " << a.output << ": changes " << summary.first_seq + 1
            << ".." << summary.last_seq << ", " << summary.changes
            << " changes, " << summary.inputs << " inputs, " << summary.blobs
            << " blobs (" << summary.blob_bytes << " B)" << std::endl;
  return kExitOk;
}

int run_replay(const ReplayArgs& a) {
  install_stop_handlers();
  auto store = db::Store::open(a.db);
  ingest::ReplayOptions options;
  options.speed = a.speed;
  options.fast = a.fast;
  options.stop = [] { return stop_requested(); };
  options.progress = [](const std::string& path, int status) {
    std::cout << path << "  " << status << std::endl;
  };
  ingest::ReplaySummary s;
  try {
    s = ingest::replay_session(a.file, *store, options);
  } catch (const std::runtime_error& e) {
    if (dynamic_cast<const StoreError*>(&e) ||
        dynamic_cast<const util::Error*>(&e))
      throw;  // an error with its own kind keeps it
    throw util::Error(util::ErrorKind::kInvalidArgument, e.what());
  }
  std::cout << "replayed " << s.captures << " captures, " << s.withdrawals
            << " withdrawals, " << s.cameras << " cameras in " << s.seconds
            << " s; " << s.failed << " refused" << std::endl;
  return s.failed == 0 ? kExitOk : kExitError;
}

void add_session_commands(CLI::App& app) {
  static SessionExportArgs export_args;
  static ReplayArgs replay_args;
  CLI::App* session = app.add_subcommand(
      "session", "record a scouting session from a store and replay it");
  session->require_subcommand(1);

  CLI::App* ex = session->add_subcommand(
      "export",
      "write the change log with the scouts' inputs (documents and photos) "
      "to a session file");
  ex->add_option("--db", export_args.db, "database URL")->required();
  ex->add_option("--since", export_args.since,
                 "start after this change seq (default: the beginning)")
      ->check(CLI::NonNegativeNumber);
  ex->add_option("-o,--output", export_args.output, "session file to write")
      ->required();
  ex->callback(
      [] { run_command([] { return run_session_export(export_args); }); });

  CLI::App* re = session->add_subcommand(
      "replay",
      "apply a session's inputs to a store through the API's handlers, "
      "keeping their rhythm");
  re->add_option("file", replay_args.file, "session file")
      ->required()
      ->check(CLI::ExistingFile);
  re->add_option("--db", replay_args.db, "database URL")->required();
  auto* speed = re->add_option("--speed", replay_args.speed,
                               "divide the recorded inter-arrival times by X")
                    ->capture_default_str()
                    ->check(CLI::PositiveNumber);
  re->add_flag("--fast", replay_args.fast, "apply the inputs back to back")
      ->excludes(speed);
  re->callback([] { run_command([] { return run_replay(replay_args); }); });
}

const CommandRegistration session_commands_registration(60,
                                                        add_session_commands);

}  // namespace
}  // namespace arscout::cli
