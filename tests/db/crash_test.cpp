// A checkpointed subscriber process is killed with SIGKILL at arbitrary
// points while a writer process produces changes, restarted from its stored
// checkpoint each time, and finally allowed to catch up. Across its runs it
// must have handled every change matching its pattern (at least once: a
// change may repeat across a restart, never go missing), each run in order,
// and each restart must resume from where the previous run's output ended.
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cctype>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <system_error>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "arscout/db/store.h"
#include "test_stores.h"
#include "tool_process.h"

extern char** environ;

namespace arscout::db {
namespace {

using namespace std::chrono_literals;
using ::testing::AssertionFailure;
using ::testing::AssertionResult;
using ::testing::AssertionSuccess;

constexpr int kWrites = 3000;
constexpr int kKills = 5;
constexpr const char* kPattern = "/data/**";
constexpr const char* kSubscriber = "crashy";
constexpr std::size_t kWholeLog = 100'000'000;

using testing::describe_status;
using testing::slurp;
using testing::ToolProcess;

// One life of the subscriber: the checkpoint it started from and the seqs it
// handled, as its "start N" line and the seq lines after it.
struct SubscriberRun {
  std::int64_t checkpoint = 0;
  std::vector<std::int64_t> seqs;
};

std::vector<SubscriberRun> parse_runs(const std::string& file) {
  std::vector<SubscriberRun> runs;
  std::ifstream in(file);
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("start ", 0) == 0) {
      runs.push_back(SubscriberRun{std::stoll(line.substr(6)), {}});
    } else if (runs.empty()) {
      ADD_FAILURE() << "output starts with '" << line << "', not a start line";
      return {};
    } else {
      runs.back().seqs.push_back(std::stoll(line));
    }
  }
  return runs;
}

// Seq lines written so far. The subscriber may be mid-line, so only complete
// lines count.
std::size_t handled(const std::string& file) {
  std::string text = slurp(file);
  std::size_t n = 0;
  for (std::size_t at = 0, end; (end = text.find('\n', at)) != text.npos;
       at = end + 1)
    if (end > at && std::isdigit(static_cast<unsigned char>(text[at]))) ++n;
  return n;
}

// Each run handles changes in increasing seq order, all after the checkpoint
// it started from.
AssertionResult RunsAreOrdered(const std::vector<SubscriberRun>& runs) {
  for (std::size_t r = 0; r < runs.size(); ++r) {
    std::int64_t prev = runs[r].checkpoint;
    for (std::int64_t seq : runs[r].seqs) {
      if (seq <= prev)
        return AssertionFailure()
               << "run " << r << " (from checkpoint " << runs[r].checkpoint
               << ") handled seq " << seq << " after " << prev;
      prev = seq;
    }
  }
  return AssertionSuccess();
}

// The checkpoint is saved only after a seq is written out, so a restart
// resumes from the last seq written before the kill, or from the one before
// it when the kill fell between the output and the checkpoint.
AssertionResult RestartsResumeWhereOutputEnded(
    const std::vector<SubscriberRun>& runs) {
  for (std::size_t r = 1; r < runs.size(); ++r) {
    std::vector<std::int64_t> before = {runs[r - 1].checkpoint};
    before.insert(before.end(), runs[r - 1].seqs.begin(),
                  runs[r - 1].seqs.end());
    const std::int64_t cp = runs[r].checkpoint;
    const std::size_t n = before.size();
    if (cp != before[n - 1] && (n < 2 || cp != before[n - 2]))
      return AssertionFailure()
             << "run " << r << " resumed from checkpoint " << cp << " but run "
             << r - 1 << " ended its output at " << before[n - 1];
  }
  return AssertionSuccess();
}

// Together the runs handled exactly the log's matching seqs: none skipped,
// none invented.
AssertionResult CoversTheLog(const std::vector<SubscriberRun>& runs,
                             const std::vector<Change>& log) {
  std::set<std::int64_t> seen;
  for (const SubscriberRun& run : runs)
    seen.insert(run.seqs.begin(), run.seqs.end());
  std::set<std::int64_t> want;
  for (const Change& c : log) want.insert(c.seq);
  for (std::int64_t seq : want)
    if (!seen.count(seq))
      return AssertionFailure() << "seq " << seq << " of " << want.size()
                                << " matching changes was never handled";
  for (std::int64_t seq : seen)
    if (!want.count(seq))
      return AssertionFailure() << "handled seq " << seq
                                << ", which is no matching change in the log";
  return AssertionSuccess();
}

class CrashTest : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    ARSCOUT_FRESH_STORE_OR_SKIP(url_, GetParam());
    store_ = Store::open(url_);
    dir_ = testing::make_temp_dir("crash");
    out_ = dir_ + "/seqs";
  }
  // A failed test leaves its files behind as evidence.
  void TearDown() override {
    if (!HasFailure() && !dir_.empty()) std::filesystem::remove_all(dir_);
  }

  std::unique_ptr<ToolProcess> start_subscriber(
      std::optional<std::int64_t> until = std::nullopt) {
    std::vector<std::string> args = {"subscribe", url_,    "--name",
                                     kSubscriber, "--out", out_,
                                     "--pattern", kPattern};
    if (until) {
      args.push_back("--until");
      args.push_back(std::to_string(*until));
    }
    return std::make_unique<ToolProcess>("store_tool", args,
                                         dir_ + "/subscriber.log");
  }

  // Waits until the subscriber's output holds `count` seqs; false when it
  // stopped or time ran out first.
  bool wait_for_output(ToolProcess& subscriber, std::size_t count) {
    const auto deadline = std::chrono::steady_clock::now() + 60s;
    while (handled(out_) < count) {
      if (!subscriber.running() || std::chrono::steady_clock::now() > deadline)
        return false;
      std::this_thread::sleep_for(5ms);
    }
    return true;
  }

  std::string url_;
  std::unique_ptr<Store> store_;
  std::string dir_;
  std::string out_;
};

TEST_P(CrashTest, KilledSubscriberResumesFromItsCheckpointWithoutGaps) {
  // Paced so that the writer is still producing while the kills land.
  ToolProcess writer("store_tool",
                     {"write", url_, "--prefix", "/data/w", "--count",
                      std::to_string(kWrites), "--pause-us", "1000"},
                     dir_ + "/writer.log");
  std::mt19937 random(std::random_device{}());
  std::vector<bool> writer_running;
  for (int life = 0; life < kKills; ++life) {
    auto subscriber = start_subscriber();
    const std::size_t target = handled(out_) + 100 + random() % 150;
    ASSERT_TRUE(wait_for_output(*subscriber, target))
        << "subscriber run " << life << " made no progress:\n"
        << slurp(dir_ + "/subscriber.log");
    // A line just appeared; wait a random part of a few delivery cycles so
    // that the kill can land anywhere in one, also between the output and
    // the checkpoint.
    std::this_thread::sleep_for(std::chrono::microseconds(random() % 20000));
    writer_running.push_back(writer.running());
    EXPECT_EQ(describe_status(subscriber->kill_now()), "signal 9")
        << slurp(dir_ + "/subscriber.log");
  }
  std::optional<int> status = writer.wait_for(120s);
  ASSERT_TRUE(status) << "writer still running after 120 s";
  ASSERT_EQ(describe_status(*status), "exit 0") << slurp(dir_ + "/writer.log");
  EXPECT_TRUE(writer_running.front())
      << "the writer finished before the first kill";

  std::vector<Change> log = store_->changes(0, kPattern, kWholeLog);
  ASSERT_GE(log.size(), std::size_t{kWrites});
  const std::int64_t last = log.back().seq;
  auto final_run = start_subscriber(last);
  status = final_run->wait_for(120s);
  ASSERT_TRUE(status) << "the last run did not catch up in 120 s";
  ASSERT_EQ(describe_status(*status), "exit 0")
      << slurp(dir_ + "/subscriber.log");

  std::vector<SubscriberRun> runs = parse_runs(out_);
  ASSERT_EQ(runs.size(), std::size_t{kKills + 1});
  std::size_t total = 0;
  for (const SubscriberRun& run : runs) total += run.seqs.size();
  std::cout << log.size() << " matching changes, handled " << total
            << " times in " << runs.size() << " runs; writer running at "
            << "the kills:";
  for (bool running : writer_running) std::cout << ' ' << running;
  std::cout << "\n";
  EXPECT_TRUE(RunsAreOrdered(runs));
  EXPECT_TRUE(RestartsResumeWhereOutputEnded(runs));
  EXPECT_TRUE(CoversTheLog(runs, log));
  EXPECT_EQ(store_->load_checkpoint(kSubscriber), last);
}

INSTANTIATE_TEST_SUITE_P(Backends, CrashTest,
                         ::testing::Values("sqlite", "postgresql"),
                         [](const auto& info) { return info.param; });

}  // namespace
}  // namespace arscout::db
