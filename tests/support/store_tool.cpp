// store_tool: a store client that the concurrency and crash tests run as a
// separate process, so that they can exercise several processes on one store
// and kill a subscriber at an arbitrary instant.
//
//   store_tool write URL --prefix P --count N [--counters K] [--results FILE]
//              [--think-us T] [--pause-us U] [--ready FILE --go FILE]
//              [--open-at-us TIME]
//     Makes N accepted writes. With K > 0 every other write is a
//     read-modify-write increment of one of K shared counters /shared/cI
//     (expected_version, retried on ConflictError; T microseconds between
//     the read and the write widen the race); the rest cycle through
//     put / patch / delete / re-create on the process's own documents under P,
//     each with the expected version, so a conflict there is a store bug.
//     Appends "OP PATH VERSION SEQ" per accepted write to FILE. --ready and
//     --go start several writers together after opening the store;
//     --open-at-us (microseconds since the epoch) opens the store at that
//     instant, so that several writers race to create it.
//
//   store_tool subscribe URL --name NAME --out FILE [--pattern P] [--until S]
//     Follows the feed from checkpoint NAME. Appends "start CHECKPOINT" once,
//     then each change's seq, to FILE, syncing each line before saving the
//     checkpoint (so delivery is at-least-once across kills). Exits 0 after
//     handling seq >= S; without --until it runs until killed.
//
// Exit status: 0 done, 1 store or I/O failure (message on stderr), 2 usage.
#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <system_error>
#include <thread>

#include <CLI/CLI.hpp>

#include "arscout/db/store.h"

namespace {

using arscout::db::ConflictError;
using arscout::db::Json;
using arscout::db::Store;
using arscout::db::WriteOp;
using arscout::db::WriteResult;
using namespace std::chrono_literals;

constexpr int kOwnDocs = 8;

struct WriteArgs {
  std::string url;
  std::string prefix;
  int count = 0;
  int counters = 0;
  int think_us = 0;
  int pause_us = 0;
  std::string results;
  std::string ready;
  std::string go;
  std::int64_t open_at_us = 0;
};

struct SubscribeArgs {
  std::string url;
  std::string name;
  std::string out;
  std::string pattern = "/**";
  std::optional<std::int64_t> until;
};

// Lets the test start several writers at the same instant, after each has
// paid for process start-up and opening the store.
void rendezvous(const WriteArgs& args) {
  if (!args.ready.empty()) std::ofstream(args.ready) << getpid() << "\n";
  if (args.go.empty()) return;
  auto deadline = std::chrono::steady_clock::now() + 60s;
  while (!std::filesystem::exists(args.go)) {
    if (std::chrono::steady_clock::now() > deadline)
      throw std::runtime_error("no go file " + args.go + " after 60 s");
    std::this_thread::sleep_for(1ms);
  }
}

class Writer {
 public:
  Writer(Store& store, const WriteArgs& args) : store_(store), args_(args) {
    if (!args.results.empty()) {
      results_.open(args.results, std::ios::trunc);
      if (!results_) throw std::runtime_error("cannot write " + args.results);
    }
  }

  void run() {
    for (int i = 0; i < args_.count; ++i) {
      if (args_.counters > 0 && i % 2 == 0) {
        increment("/shared/c" + std::to_string((i / 2) % args_.counters));
      } else {
        write_own(args_.counters > 0 ? i / 2 : i);
      }
      if (args_.pause_us > 0)
        std::this_thread::sleep_for(std::chrono::microseconds(args_.pause_us));
    }
    results_.flush();
    if (!results_) throw std::runtime_error("writing the results failed");
    std::cout << "wrote " << args_.count << " conflicts " << conflicts_
              << std::endl;
  }

 private:
  // Other writers race us between the read and the write; a conflict means
  // we lost the race and must read again.
  void increment(const std::string& path) {
    for (;;) {
      auto doc = store_.get(path);
      std::int64_t version = doc ? doc->version : 0;
      std::int64_t n = doc ? doc->attrs.value("n", std::int64_t{0}) : 0;
      if (args_.think_us > 0)
        std::this_thread::sleep_for(std::chrono::microseconds(args_.think_us));
      try {
        record("inc", store_.put(path, "counter", Json{{"n", n + 1}}, version));
        return;
      } catch (const ConflictError&) {
        ++conflicts_;
      }
    }
  }

  // Only this process writes under its prefix, so the expected version it
  // tracks must always hold.
  void write_own(int j) {
    const std::string path = args_.prefix + "/d" + std::to_string(j % kOwnDocs);
    const int round = j / kOwnDocs;
    std::int64_t& version = versions_[path];
    bool& live = live_[path];
    WriteOp op;
    switch (round % 4) {
      case 1:
        op = WriteOp::patch(path, Json{{"patched", round}}, version);
        break;
      case 2:
        op = WriteOp::remove(path, version);
        break;
      default:
        op = WriteOp::put(path, "item", Json{{"round", round}},
                          live ? version : 0);
    }
    WriteResult r = store_.write(op);
    if (r.version != version + 1)
      throw std::runtime_error(path + " went from version " +
                               std::to_string(version) + " to " +
                               std::to_string(r.version));
    version = r.version;
    live = op.type != arscout::db::OpType::kDelete;
    record(arscout::db::to_string(op.type), r);
  }

  void record(const std::string& op, const WriteResult& r) {
    if (results_.is_open())
      results_ << op << ' ' << r.path << ' ' << r.version << ' ' << r.seq
               << '\n';
  }

  Store& store_;
  const WriteArgs& args_;
  std::ofstream results_;
  std::map<std::string, std::int64_t> versions_;
  std::map<std::string, bool> live_;
  std::int64_t conflicts_ = 0;
};

// An append-only file whose every line is on disk before append returns.
class SyncedLines {
 public:
  explicit SyncedLines(const std::string& path)
      : fd_(::open(path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC,
                   0644)) {
    if (fd_ < 0) throw std::system_error(errno, std::generic_category(), path);
  }
  ~SyncedLines() { ::close(fd_); }
  SyncedLines(const SyncedLines&) = delete;
  SyncedLines& operator=(const SyncedLines&) = delete;

  // One write() per line, so a kill never leaves half a line behind.
  void append(const std::string& text) {
    std::string line = text + "\n";
    ssize_t n = ::write(fd_, line.data(), line.size());
    if (n != static_cast<ssize_t>(line.size()) || ::fdatasync(fd_) != 0)
      throw std::system_error(errno, std::generic_category(), "append");
  }

 private:
  int fd_;
};

int run_write(const WriteArgs& args) {
  std::this_thread::sleep_until(std::chrono::system_clock::time_point(
      std::chrono::microseconds(args.open_at_us)));
  auto store = Store::open(args.url);
  Writer writer(*store, args);
  rendezvous(args);
  writer.run();
  return 0;
}

int run_subscribe(const SubscribeArgs& args) {
  auto store = Store::open(args.url);
  const std::int64_t from = store->load_checkpoint(args.name);
  SyncedLines out(args.out);
  out.append("start " + std::to_string(from));
  if (args.until && from >= *args.until) return 0;
  std::atomic<bool> done{false};
  // Output first, checkpoint second: a kill in between repeats this change
  // after a restart instead of losing it.
  auto handle = [&](const arscout::db::Change& change) {
    out.append(std::to_string(change.seq));
    store->save_checkpoint(args.name, change.seq);
    if (args.until && change.seq >= *args.until) done = true;
  };
  auto sub = store->subscribe(args.pattern, from, handle);
  while (!done) {
    std::string error = sub->error();
    if (!error.empty()) {
      std::cerr << "store_tool: subscription failed: " << error << std::endl;
      return 1;
    }
    std::this_thread::sleep_for(5ms);
  }
  sub->stop();
  return 0;
}

void add_write_command(CLI::App& app, WriteArgs& args, int& status) {
  auto* cmd = app.add_subcommand("write", "make N accepted writes");
  cmd->add_option("url", args.url)->required();
  cmd->add_option("--prefix", args.prefix)->required();
  cmd->add_option("--count", args.count)->required();
  cmd->add_option("--counters", args.counters);
  cmd->add_option("--think-us", args.think_us);
  cmd->add_option("--pause-us", args.pause_us);
  cmd->add_option("--results", args.results);
  cmd->add_option("--ready", args.ready);
  cmd->add_option("--go", args.go);
  cmd->add_option("--open-at-us", args.open_at_us);
  cmd->callback([&] { status = run_write(args); });
}

void add_subscribe_command(CLI::App& app, SubscribeArgs& args, int& status) {
  auto* cmd = app.add_subcommand("subscribe", "follow the feed, checkpointed");
  cmd->add_option("url", args.url)->required();
  cmd->add_option("--name", args.name)->required();
  cmd->add_option("--out", args.out)->required();
  cmd->add_option("--pattern", args.pattern);
  cmd->add_option("--until", args.until);
  cmd->callback([&] { status = run_subscribe(args); });
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"store client for the arscout concurrency and crash tests"};
  app.require_subcommand(1);
  WriteArgs write_args;
  SubscribeArgs subscribe_args;
  int status = 0;
  add_write_command(app, write_args, status);
  add_subscribe_command(app, subscribe_args, status);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  } catch (const std::exception& e) {
    std::cerr << "store_tool: " << e.what() << std::endl;
    return 1;
  }
  return status;
}
