// Many writers on one store at once, as threads of one process (both
// backends) and as separate processes on one SQLite file. However the writes
// interleave, the change log must hold every accepted write exactly once,
// with seqs 1..N and consecutive versions per document; shared counters must
// count every accepted increment; and live subscribers must see exactly the
// log, in order.
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <sstream>
#include <string>
#include <system_error>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "arscout/db/store.h"
#include "store_fixture.h"
#include "test_stores.h"
#include "tool_process.h"

extern char** environ;

namespace arscout::db {
namespace {

using namespace std::chrono_literals;
using ::testing::AssertionFailure;
using ::testing::AssertionResult;
using ::testing::AssertionSuccess;

constexpr int kThreads = 8;
constexpr int kWritesPerThread = 500;
constexpr int kCounters = 3;
constexpr int kOwnDocs = 5;
constexpr std::size_t kWholeLog = 100'000'000;

// One accepted write, as its writer was told.
struct Accepted {
  OpType op = OpType::kPut;
  bool increment = false;  // a put that bumped a shared counter
  WriteResult result;
};

// ------------------------------------------------------------ log checks

// Every accepted write is in the log exactly once with its path, version and
// op; the log holds nothing else; seqs run 1..N without holes.
AssertionResult LogHoldsExactly(const std::vector<Change>& log,
                                const std::vector<Accepted>& accepted) {
  std::map<std::int64_t, const Accepted*> by_seq;
  for (const Accepted& a : accepted)
    if (!by_seq.emplace(a.result.seq, &a).second)
      return AssertionFailure()
             << "two accepted writes were given seq " << a.result.seq;
  if (log.size() != accepted.size())
    return AssertionFailure() << "the log has " << log.size() << " changes for "
                              << accepted.size() << " accepted writes";
  for (std::size_t i = 0; i < log.size(); ++i) {
    const Change& c = log[i];
    const auto want = static_cast<std::int64_t>(i + 1);
    if (c.seq != want)
      return AssertionFailure() << "log entry " << i << " has seq " << c.seq
                                << ", expected " << want << " (no holes)";
    auto it = by_seq.find(c.seq);
    if (it == by_seq.end())
      return AssertionFailure() << "seq " << c.seq << " (" << c.path
                                << ") was never returned to a writer";
    const Accepted& a = *it->second;
    if (a.result.path != c.path || a.result.version != c.version ||
        a.op != c.op)
      return AssertionFailure()
             << "seq " << c.seq << ": log says " << to_string(c.op) << " "
             << c.path << " v" << c.version << ", writer was told "
             << to_string(a.op) << " " << a.result.path << " v"
             << a.result.version;
  }
  return AssertionSuccess();
}

// Per document the log's versions run 1, 2, 3... (deletes included) and end
// at what the store holds now.
AssertionResult VersionsAreConsecutive(Store& store,
                                       const std::vector<Change>& log) {
  std::map<std::string, const Change*> last;
  for (const Change& c : log) {
    const Change*& prev = last[c.path];
    const std::int64_t want = prev ? prev->version + 1 : 1;
    if (c.version != want)
      return AssertionFailure() << c.path << " has version " << c.version
                                << " at seq " << c.seq << ", expected " << want;
    prev = &c;
  }
  for (const auto& [path, c] : last) {
    auto doc = store.get(path);
    if (c->op == OpType::kDelete) {
      if (doc) return AssertionFailure() << path << " is live after a delete";
      continue;
    }
    if (!doc || doc->version != c->version || doc->seq != c->seq)
      return AssertionFailure() << path << ": the log ends at v" << c->version
                                << " seq " << c->seq << ", get() says "
                                << (doc ? "v" + std::to_string(doc->version) +
                                              " seq " + std::to_string(doc->seq)
                                        : std::string("nothing"));
  }
  return AssertionSuccess();
}

// Each counter went 1, 2, 3... one version per accepted increment.
AssertionResult CountersMatch(Store& store,
                              const std::vector<Accepted>& accepted) {
  std::map<std::string, std::int64_t> increments;
  for (const Accepted& a : accepted)
    if (a.increment) ++increments[a.result.path];
  if (increments.empty()) return AssertionFailure() << "no increments";
  for (const auto& [path, n] : increments) {
    auto doc = store.get(path);
    if (!doc) return AssertionFailure() << path << " is missing";
    if (doc->attrs.value("n", std::int64_t{-1}) != n || doc->version != n)
      return AssertionFailure()
             << path << " holds n=" << doc->attrs.dump() << " at v"
             << doc->version << " after " << n << " accepted increments";
  }
  return AssertionSuccess();
}

// A subscriber saw the log's changes, all of them, once each, in order.
AssertionResult SameChanges(const std::vector<Change>& seen,
                            const std::vector<Change>& log) {
  for (std::size_t i = 1; i < seen.size(); ++i)
    if (seen[i].seq <= seen[i - 1].seq)
      return AssertionFailure()
             << "delivered seq " << seen[i].seq << " after " << seen[i - 1].seq;
  if (seen.size() != log.size())
    return AssertionFailure()
           << "delivered " << seen.size() << " of " << log.size() << " changes";
  for (std::size_t i = 0; i < log.size(); ++i)
    if (seen[i].seq != log[i].seq || seen[i].path != log[i].path ||
        seen[i].version != log[i].version || seen[i].op != log[i].op)
      return AssertionFailure() << "delivery " << i << " is seq " << seen[i].seq
                                << " " << seen[i].path << ", the log has seq "
                                << log[i].seq << " " << log[i].path;
  return AssertionSuccess();
}

std::vector<Change> matching(const std::vector<Change>& log,
                             const std::string& prefix) {
  std::vector<Change> out;
  for (const Change& c : log)
    if (c.path.compare(0, prefix.size(), prefix) == 0) out.push_back(c);
  return out;
}

// ------------------------------------------------------------ subscribers

// Keeps what a live subscription delivers.
class Recorder {
 public:
  Recorder(Store& store, const std::string& pattern)
      : sub_(store.subscribe(pattern, 0, [this](const Change& c) {
          std::lock_guard lock(mu_);
          seen_.push_back(c);
        })) {}

  // True once everything up to seq was delivered; false after the timeout or
  // when delivery failed.
  bool caught_up(std::int64_t seq, std::chrono::seconds timeout) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (sub_->last_seq() < seq) {
      if (!sub_->error().empty() || std::chrono::steady_clock::now() > deadline)
        return false;
      std::this_thread::sleep_for(10ms);
    }
    return true;
  }

  std::vector<Change> stop() {
    sub_->stop();
    std::lock_guard lock(mu_);
    return seen_;
  }
  std::string error() const { return sub_->error(); }

 private:
  std::mutex mu_;
  std::vector<Change> seen_;
  std::unique_ptr<Subscription> sub_;
};

// The subscriber must reach the end of the log, and then match it.
void ExpectDelivered(Recorder& recorder, const std::vector<Change>& log,
                     std::int64_t head) {
  EXPECT_TRUE(recorder.caught_up(head, 60s))
      << "subscriber stuck; error: " << recorder.error();
  std::vector<Change> seen = recorder.stop();
  EXPECT_EQ(recorder.error(), "");
  EXPECT_TRUE(SameChanges(seen, log));
}

// ------------------------------------------------------------ thread writers

// One writer thread's workload: read-modify-write increments of shared
// counters (racing the other threads), writes to documents of its own, some
// of both in one batch, and deliberately stale writes that must conflict.
class ThreadWriter {
 public:
  ThreadWriter(Store& store, int id)
      : store_(store), prefix_("/own/t" + std::to_string(id)), id_(id) {}

  void run() {
    try {
      for (int i = 0; i < kWritesPerThread; ++i) step(i);
    } catch (const std::exception& e) {
      errors_.push_back(prefix_ + ": " + e.what());
    }
  }

  const std::vector<Accepted>& accepted() const { return accepted_; }
  const std::vector<std::string>& errors() const { return errors_; }
  int lost_races() const { return lost_races_; }

 private:
  struct Own {
    std::int64_t version = 0;  // latest, tombstones included
    bool live = false;
  };

  void step(int i) {
    const std::string counter =
        "/shared/c" + std::to_string((id_ + i) % kCounters);
    if (i % 10 == 9) {
      increment_with_own_write(counter, i);
    } else if (i % 2 == 0) {
      increment(counter);
    } else {
      write_own(i);
    }
    if (i % 25 == 24) stale_writes(counter, i);
  }

  // Other threads race us between get and put; losing is a ConflictError,
  // and then we read again.
  void increment(const std::string& path) {
    for (;;) {
      WriteOp op = next_increment(path);
      try {
        accept(op, store_.write(op), /*increment=*/true);
        return;
      } catch (const ConflictError&) {
        ++lost_races_;
      }
    }
  }

  // Both or neither: a lost race must leave the own document untouched.
  void increment_with_own_write(const std::string& counter, int i) {
    for (;;) {
      std::vector<WriteOp> ops = {next_increment(counter), next_own(i)};
      try {
        std::vector<WriteResult> results = store_.batch(ops);
        if (results.size() != 2 || results[1].seq != results[0].seq + 1)
          throw std::runtime_error("a batch of two got non-consecutive seqs");
        accept(ops[0], results[0], /*increment=*/true);
        accept(ops[1], results[1], /*increment=*/false);
        return;
      } catch (const ConflictError& e) {
        if (e.path() != counter) throw;
        ++lost_races_;
      }
    }
  }

  void write_own(int i) {
    WriteOp op = next_own(i);
    accept(op, store_.write(op), /*increment=*/false);
  }

  WriteOp next_increment(const std::string& path) {
    auto doc = store_.get(path);
    std::int64_t n = doc ? doc->attrs.value("n", std::int64_t{0}) : 0;
    return WriteOp::put(path, "counter", Json{{"n", n + 1}},
                        doc ? doc->version : 0);
  }

  // Cycles put, patch, delete, re-create; only this thread writes here, so
  // the expected version always holds.
  WriteOp next_own(int i) {
    const std::string path = own_path(i);
    const Own& own = own_[path];
    const int round = i / (2 * kOwnDocs);
    switch (round % 4) {
      case 1:
        return WriteOp::patch(path, Json{{"patched", i}}, own.version);
      case 2:
        return WriteOp::remove(path, own.version);
      default:
        return WriteOp::put(path, "item", Json{{"i", i}},
                            own.live ? own.version : 0);
    }
  }

  std::string own_path(int i) const {
    return prefix_ + "/d" + std::to_string((i / 2) % kOwnDocs);
  }

  void accept(const WriteOp& op, const WriteResult& r, bool increment) {
    accepted_.push_back(Accepted{op.type, increment, r});
    if (increment) return;
    Own& own = own_[op.path];
    if (r.version != own.version + 1)
      throw std::runtime_error(op.path + " jumped from v" +
                               std::to_string(own.version) + " to v" +
                               std::to_string(r.version));
    own = Own{r.version, op.type != OpType::kDelete};
  }

  // A version that cannot hold must be refused, naming the current one.
  void stale_writes(const std::string& counter, int i) {
    if (auto doc = store_.get(counter))
      expect_conflict(
          WriteOp::put(counter, "counter", Json{{"n", -1}}, doc->version - 1),
          doc->version, /*exact=*/false);
    const Own& own = own_[own_path(i)];
    expect_conflict(WriteOp::put(own_path(i), "item", Json{{"stale", true}},
                                 own.version + 7),
                    own.live ? own.version : 0, /*exact=*/true);
  }

  // Counters move on under us, so for them `current` is a lower bound.
  void expect_conflict(const WriteOp& op, std::int64_t current, bool exact) {
    try {
      WriteResult r = store_.write(op);
      accepted_.push_back(Accepted{op.type, false, r});
      errors_.push_back("stale write to " + op.path + " accepted as seq " +
                        std::to_string(r.seq));
    } catch (const ConflictError& e) {
      bool ok = e.path() == op.path &&
                e.expected_version() == *op.expected_version &&
                (exact ? e.current_version() == current
                       : e.current_version() >= current);
      if (!ok)
        errors_.push_back("conflict on " + op.path + " says expected " +
                          std::to_string(e.expected_version()) + " current " +
                          std::to_string(e.current_version()) +
                          "; wanted current " + std::to_string(current));
    }
  }

  Store& store_;
  const std::string prefix_;
  const int id_;
  std::map<std::string, Own> own_;
  std::vector<Accepted> accepted_;
  std::vector<std::string> errors_;
  int lost_races_ = 0;
};

using ConcurrencyTest = ::arscout::testing::FreshStoreTest;

TEST_P(ConcurrencyTest, ThreadsWithConflictsKeepTheLogExact) {
  Recorder everything(*store_, "/**");
  Recorder counters(*store_, "/shared/**");
  std::vector<std::unique_ptr<ThreadWriter>> writers;
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    writers.push_back(std::make_unique<ThreadWriter>(*store_, t));
    threads.emplace_back([w = writers.back().get()] { w->run(); });
  }
  for (std::thread& t : threads) t.join();

  std::vector<Accepted> accepted;
  int lost_races = 0;
  for (const auto& w : writers) {
    for (const std::string& e : w->errors()) ADD_FAILURE() << e;
    accepted.insert(accepted.end(), w->accepted().begin(), w->accepted().end());
    lost_races += w->lost_races();
  }
  std::cout << "accepted " << accepted.size() << " writes, " << lost_races
            << " lost read-modify-write races\n";
  ASSERT_GE(accepted.size(), std::size_t{kThreads * kWritesPerThread});

  const std::int64_t head = store_->last_seq();
  std::vector<Change> log = store_->changes(0, "/**", kWholeLog);
  EXPECT_EQ(head, static_cast<std::int64_t>(log.size()));
  EXPECT_TRUE(LogHoldsExactly(log, accepted));
  EXPECT_TRUE(VersionsAreConsecutive(*store_, log));
  EXPECT_TRUE(CountersMatch(*store_, accepted));
  ExpectDelivered(everything, log, head);
  std::vector<Change> shared = matching(log, "/shared/");
  ASSERT_FALSE(shared.empty());
  ExpectDelivered(counters, shared, shared.back().seq);
}

// A retry racing the attempt whose answer was lost stores the same bytes
// twice at once; both must succeed with the one blob (on PostgreSQL the
// second insert used to fail on the primary key).
TEST_P(ConcurrencyTest, TheSameBlobPutAtOnceIsStoredOnce) {
  constexpr int kRounds = 20, kPutters = 4;
  for (int round = 0; round < kRounds; ++round) {
    const std::string bytes(300000 + round, static_cast<char>('a' + round));
    std::vector<std::string> hashes(kPutters), errors(kPutters);
    std::vector<std::thread> putters;
    for (int p = 0; p < kPutters; ++p)
      putters.emplace_back([&, p] {
        try {
          hashes[p] = store_->put_blob(bytes);
        } catch (const std::exception& e) {
          errors[p] = e.what();
        }
      });
    for (auto& t : putters) t.join();
    for (int p = 0; p < kPutters; ++p) {
      EXPECT_EQ(errors[p], "") << "round " << round;
      EXPECT_EQ(hashes[p], hashes[0]);
    }
    EXPECT_EQ(store_->get_blob(hashes[0]), bytes);
  }
  EXPECT_EQ(store_->stats().blobs, kRounds);
}

INSTANTIATE_TEST_SUITE_P(Backends, ConcurrencyTest,
                         ::testing::Values("sqlite", "postgresql"),
                         [](const auto& info) { return info.param; });

// ------------------------------------------------------------ processes

using testing::describe_status;
using testing::slurp;
using testing::ToolProcess;

// The "OP PATH VERSION SEQ" lines store_tool write leaves behind.
std::vector<Accepted> read_results(const std::string& file) {
  std::vector<Accepted> out;
  std::ifstream in(file);
  std::string op;
  Accepted a;
  while (in >> op >> a.result.path >> a.result.version >> a.result.seq) {
    a.increment = op == "inc";
    a.op = op == "patch"    ? OpType::kPatch
           : op == "delete" ? OpType::kDelete
                            : OpType::kPut;
    out.push_back(a);
  }
  return out;
}

// The N of the "wrote ... conflicts N" line store_tool write ends with.
int reported_conflicts(const std::string& output) {
  const std::string tag = "conflicts ";
  auto at = output.rfind(tag);
  return at == std::string::npos ? 0
                                 : std::stoi(output.substr(at + tag.size()));
}

// Waits until every writer has written its ready file; false when one of
// them exited first or time ran out.
bool all_ready(std::vector<std::unique_ptr<ToolProcess>>& procs,
               const std::vector<std::string>& ready) {
  const auto deadline = std::chrono::steady_clock::now() + 60s;
  for (std::size_t p = 0; p < procs.size(); ++p) {
    while (!std::filesystem::exists(ready[p])) {
      if (procs[p]->wait_for(0ms) ||
          std::chrono::steady_clock::now() > deadline)
        return false;
      std::this_thread::sleep_for(5ms);
    }
  }
  return true;
}

// How often consecutive seqs come from different processes: 1 means one
// process ran entirely before the other.
int count_switches(const std::vector<Change>& log,
                   const std::vector<std::vector<Accepted>>& per_process) {
  std::map<std::int64_t, std::size_t> owner;
  for (std::size_t p = 0; p < per_process.size(); ++p)
    for (const Accepted& a : per_process[p]) owner[a.result.seq] = p;
  int switches = 0;
  for (std::size_t i = 1; i < log.size(); ++i)
    if (owner[log[i].seq] != owner[log[i - 1].seq]) ++switches;
  return switches;
}

constexpr int kProcesses = 2;
constexpr int kWritesPerProcess = 600;

// A temp directory, deleted at the end of a test that passed (a failed one
// leaves it behind as evidence). Declare it before what uses it.
struct ScratchDir {
  explicit ScratchDir(const std::string& tag)
      : path(testing::make_temp_dir(tag)) {}
  ~ScratchDir() {
    if (!::testing::Test::HasFailure()) std::filesystem::remove_all(path);
  }
  const std::string path;
};

std::string all_logs(const std::vector<std::string>& logs) {
  std::string text;
  for (const std::string& log : logs) text += log + ":\n" + slurp(log) + "\n";
  return text;
}

// Two processes write to one SQLite file together, fighting over shared
// counters; a subscriber in this process can only find their commits by
// polling the file.
TEST(ConcurrencyProcesses, TwoSqliteProcessesShareOneFile) {
  const ScratchDir scratch("procs");
  const std::string& dir = scratch.path;
  const std::string url = "sqlite:" + dir + "/store.db";
  auto store = Store::open(url);
  Recorder everything(*store, "/**");
  std::vector<std::unique_ptr<ToolProcess>> procs;
  std::vector<std::string> ready, results, logs;
  for (int p = 0; p < kProcesses; ++p) {
    const std::string tag = dir + "/p" + std::to_string(p);
    ready.push_back(tag + ".ready");
    results.push_back(tag + ".results");
    logs.push_back(tag + ".log");
    procs.push_back(std::make_unique<ToolProcess>(
        "store_tool",
        std::vector<std::string>{
            "write", url, "--prefix", "/own/p" + std::to_string(p), "--count",
            std::to_string(kWritesPerProcess), "--counters",
            std::to_string(kCounters), "--think-us", "200", "--results",
            results.back(), "--ready", ready.back(), "--go", dir + "/go"},
        logs.back()));
  }
  // Both start writing at once, so that they really overlap.
  ASSERT_TRUE(all_ready(procs, ready)) << all_logs(logs);
  std::ofstream(dir + "/go") << "go\n";

  std::vector<std::vector<Accepted>> per_process;
  std::vector<Accepted> accepted;
  int lost_races = 0;
  for (int p = 0; p < kProcesses; ++p) {
    std::optional<int> status = procs[p]->wait_for(90s);
    ASSERT_TRUE(status) << "writer " << p << " still running after 90 s";
    ASSERT_EQ(describe_status(*status), "exit 0") << slurp(logs[p]);
    std::cout << "writer " << p << ": " << slurp(logs[p]);
    lost_races += reported_conflicts(slurp(logs[p]));
    per_process.push_back(read_results(results[p]));
    EXPECT_EQ(per_process.back().size(), std::size_t{kWritesPerProcess});
    accepted.insert(accepted.end(), per_process.back().begin(),
                    per_process.back().end());
  }

  const std::int64_t head = store->last_seq();
  std::vector<Change> log = store->changes(0, "/**", kWholeLog);
  EXPECT_TRUE(LogHoldsExactly(log, accepted));
  EXPECT_TRUE(VersionsAreConsecutive(*store, log));
  EXPECT_TRUE(CountersMatch(*store, accepted));
  const int switches = count_switches(log, per_process);
  std::cout << "the processes' writes alternate " << switches << " times\n";
  EXPECT_GE(switches, 2) << "the writers did not overlap";
  EXPECT_GT(lost_races, 0) << "the writers never raced for a counter";
  ExpectDelivered(everything, log, head);
}

// Processes opening one new SQLite file at the same moment must all get a
// working store: one creates the schema, the others wait for it. The race is
// narrow, so the openers are timed to the same instant, many times over.
TEST(ConcurrencyProcesses, ProcessesCreateOneSqliteFileTogether) {
  constexpr int kRounds = 30;
  constexpr int kOpeners = 6;
  const ScratchDir scratch("create");
  const std::string& dir = scratch.path;
  for (int round = 0; round < kRounds; ++round) {
    const std::string url = "sqlite:" + dir + "/r" + std::to_string(round);
    std::vector<std::unique_ptr<ToolProcess>> procs;
    std::vector<std::string> logs;
    const auto open_at = std::chrono::duration_cast<std::chrono::microseconds>(
        (std::chrono::system_clock::now() + 150ms).time_since_epoch());
    for (int p = 0; p < kOpeners; ++p) {
      logs.push_back(dir + "/r" + std::to_string(round) + "-p" +
                     std::to_string(p) + ".log");
      procs.push_back(std::make_unique<ToolProcess>(
          "store_tool",
          std::vector<std::string>{
              "write", url, "--prefix", "/p" + std::to_string(p), "--count",
              "1", "--open-at-us", std::to_string(open_at.count())},
          logs.back()));
    }
    for (int p = 0; p < kOpeners; ++p) {
      std::optional<int> status = procs[p]->wait_for(60s);
      ASSERT_TRUE(status) << "round " << round << ": opener " << p << " hangs";
      ASSERT_EQ(describe_status(*status), "exit 0")
          << "round " << round << ", opener " << p << " of " << kOpeners
          << ":\n"
          << slurp(logs[p]);
    }
    ASSERT_EQ(Store::open(url)->last_seq(), kOpeners) << "round " << round;
  }
}

}  // namespace
}  // namespace arscout::db
