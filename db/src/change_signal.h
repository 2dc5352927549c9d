// Wakes waiters when the log grows: the in-process half of change
// notification. Writers (or a LISTEN thread) publish the newest seq they know
// of; waiters block until it passes theirs or a timeout elapses.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>

namespace arscout::db::internal {

class ChangeSignal {
 public:
  void publish(std::int64_t seq) {
    {
      std::lock_guard lock(mu_);
      if (seq <= known_) return;
      known_ = seq;
    }
    cv_.notify_all();
  }

  void wait(std::int64_t after, std::chrono::milliseconds timeout) {
    std::unique_lock lock(mu_);
    cv_.wait_for(lock, timeout, [&] { return known_ > after; });
  }

 private:
  std::mutex mu_;
  std::condition_variable cv_;
  std::int64_t known_ = 0;
};

}  // namespace arscout::db::internal
