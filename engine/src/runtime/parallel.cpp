#include "runtime/parallel.h"

#include <algorithm>
#include <atomic>
#include <exception>
#include <thread>
#include <vector>

namespace arscout::engine {

void run_workers(int workers, const std::function<void(int worker)>& work) {
  if (workers <= 1) {
    work(0);
    return;
  }
  std::vector<std::exception_ptr> errors(workers);
  const auto guarded = [&](int w) {
    try {
      work(w);
    } catch (...) {
      errors[w] = std::current_exception();
    }
  };
  std::vector<std::thread> threads;
  threads.reserve(workers - 1);
  for (int w = 0; w + 1 < workers; ++w) threads.emplace_back(guarded, w);
  guarded(workers - 1);
  for (std::thread& t : threads) t.join();
  for (const std::exception_ptr& error : errors)
    if (error) std::rethrow_exception(error);
}

void run_tasks(std::size_t count, int threads,
               const std::function<void(std::size_t task)>& task) {
  const std::size_t most = std::max(1, threads);
  const int workers =
      static_cast<int>(std::max<std::size_t>(1, std::min(most, count)));
  std::atomic<std::size_t> next{0};
  run_workers(workers, [&](int) {
    for (std::size_t k = next++; k < count; k = next++) task(k);
  });
}

}  // namespace arscout::engine
