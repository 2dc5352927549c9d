#include "change_watch.h"

#include <vector>

#include <spdlog/spdlog.h>

namespace arscout::ingest {

ChangeWatch::ChangeWatch(db::Store& store, std::chrono::milliseconds poll)
    : store_(store), poll_(poll) {
  thread_ = std::thread([this] { run(); });
}

ChangeWatch::~ChangeWatch() { stop(); }

std::uint64_t ChangeWatch::notify_after(std::int64_t after,
                                        std::function<void()> wake) {
  std::unique_lock lock(mu_);
  if (stopping_) return 0;
  if (known_head_ > after) {
    lock.unlock();
    wake();
    return 0;
  }
  const std::uint64_t id = next_id_++;
  waiters_.emplace(id, Waiter{after, std::move(wake)});
  idle_.notify_one();
  return id;
}

void ChangeWatch::cancel(std::uint64_t id) {
  std::lock_guard lock(mu_);
  waiters_.erase(id);
}

void ChangeWatch::stop() {
  {
    std::lock_guard lock(mu_);
    stopping_ = true;
    waiters_.clear();
  }
  idle_.notify_all();
  if (thread_.joinable()) thread_.join();
}

std::size_t ChangeWatch::waiting() const {
  std::lock_guard lock(mu_);
  return waiters_.size();
}

// Nobody waiting: the thread sleeps and reads nothing. Otherwise it reads
// the head, wakes those it passed, and waits for the store's next commit.
void ChangeWatch::run() {
  while (true) {
    {
      std::unique_lock lock(mu_);
      idle_.wait(lock, [&] { return stopping_ || !waiters_.empty(); });
      if (stopping_) return;
    }
    std::int64_t head = 0;
    try {
      head = store_.last_seq();
    } catch (const std::exception& e) {
      spdlog::warn("event=change_watch_retry error=\"{}\"", e.what());
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
      continue;
    }
    wake_past(head);
    store_.wait_for_change(head, poll_);
  }
}

void ChangeWatch::wake_past(std::int64_t head) {
  std::vector<std::function<void()>> woken;
  {
    std::lock_guard lock(mu_);
    if (head > known_head_) known_head_ = head;
    for (auto it = waiters_.begin(); it != waiters_.end();) {
      if (it->second.after < head) {
        woken.push_back(std::move(it->second.wake));
        it = waiters_.erase(it);
      } else {
        ++it;
      }
    }
  }
  for (auto& wake : woken) wake();
}

}  // namespace arscout::ingest
