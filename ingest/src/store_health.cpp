#include "store_health.h"

namespace arscout::ingest {

StoreHealth::Reading StoreHealth::read_now() {
  Reading r;
  try {
    r.last_seq = store_.last_seq();
    r.ok = true;
  } catch (const db::StoreError& e) {
    r.error = e.what();
  }
  return r;
}

void StoreHealth::start(std::chrono::milliseconds every) {
  std::lock_guard lock(mutex_);
  if (running_) return;
  running_ = true;
  every_ = every;
  thread_ = std::thread([this] {
    std::unique_lock lock(mutex_);
    while (!stopping_) {
      lock.unlock();
      Reading r = read_now();
      lock.lock();
      last_ = std::move(r);
      last_at_ = std::chrono::steady_clock::now();
      wake_.wait_for(lock, every_, [&] { return stopping_; });
    }
  });
}

void StoreHealth::stop() {
  {
    std::lock_guard lock(mutex_);
    if (!running_) return;
    stopping_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
  std::lock_guard lock(mutex_);
  running_ = false;
}

StoreHealth::Reading StoreHealth::check() {
  {
    std::lock_guard lock(mutex_);
    if (running_) {
      const auto age = std::chrono::steady_clock::now() - last_at_;
      if (last_at_.time_since_epoch().count() != 0 && age <= 4 * every_)
        return last_;
      Reading stale;
      stale.error =
          last_at_.time_since_epoch().count() == 0
              ? "the store has not answered yet"
              : "the store has not answered for " +
                    std::to_string(
                        std::chrono::duration_cast<std::chrono::milliseconds>(
                            age)
                            .count()) +
                    " ms";
      return stale;
    }
  }
  return read_now();
}

}  // namespace arscout::ingest
