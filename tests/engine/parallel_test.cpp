// The core's coarse parallel work (parallel.h): every task runs once, on
// no more workers than asked, and a failure reaches the caller only after
// every worker has stopped.
#include "runtime/parallel.h"

#include <atomic>
#include <chrono>
#include <mutex>
#include <set>
#include <stdexcept>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

namespace arscout::engine {
namespace {

TEST(RunTasks, RunsEveryTaskOnceOnAtMostTheThreadsAsked) {
  for (const int threads : {1, 2, 3}) {
    for (const std::size_t count : {0u, 1u, 2u, 7u, 40u}) {
      std::vector<int> runs(count, 0);
      std::mutex mutex;
      std::set<std::thread::id> workers;
      run_tasks(count, threads, [&](std::size_t k) {
        std::lock_guard lock(mutex);
        ++runs[k];
        workers.insert(std::this_thread::get_id());
      });
      for (std::size_t k = 0; k < count; ++k)
        EXPECT_EQ(runs[k], 1) << "task " << k << " of " << count;
      EXPECT_LE(workers.size(), static_cast<std::size_t>(threads));
      if (count == 1) {
        EXPECT_EQ(*workers.begin(), std::this_thread::get_id());
      }
    }
  }
}

TEST(RunTasks, UsesTheThreadsWhenTasksWait) {
  // Two tasks that each wait for the other to start finish only when they
  // run at once: on one thread the first would wait for ever (bounded here).
  std::atomic<int> started{0};
  std::atomic<bool> both_ran_together{true};
  run_tasks(2, 2, [&](std::size_t) {
    ++started;
    const auto until =
        std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (started.load() < 2 && std::chrono::steady_clock::now() < until)
      std::this_thread::yield();
    if (started.load() < 2) both_ran_together = false;
  });
  EXPECT_TRUE(both_ran_together);
}

TEST(RunWorkers, RethrowsAfterEveryWorkerHasStopped) {
  std::atomic<int> finished{0};
  EXPECT_THROW(
      run_workers(3,
                  [&](int worker) {
                    if (worker == 1) throw std::runtime_error("one");
                    std::this_thread::sleep_for(std::chrono::milliseconds(50));
                    ++finished;
                  }),
      std::runtime_error);
  EXPECT_EQ(finished.load(), 2);  // the others ran to their end first
}

TEST(RunWorkers, OneWorkerRunsOnTheCallersThread) {
  std::thread::id ran_on;
  run_workers(1, [&](int) { ran_on = std::this_thread::get_id(); });
  EXPECT_EQ(ran_on, std::this_thread::get_id());
  EXPECT_THROW(run_workers(1, [](int) { throw std::invalid_argument("x"); }),
               std::invalid_argument);
}

}  // namespace
}  // namespace arscout::engine
