// One thread per server that follows the head of the change log and wakes
// whoever waits for it to move: long-polls and WebSocket streams wait here
// instead of holding a worker thread each (docs/RELIABILITY.md, "Hostile
// clients"). Knows nothing of sockets.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <thread>

#include "arscout/db/store.h"

namespace arscout::ingest {

class ChangeWatch {
 public:
  // `poll` bounds how late a write by another process is noticed where the
  // store has no wake-up for it (SQLite); in-process writes and PostgreSQL
  // notifications wake the watch at once.
  ChangeWatch(db::Store& store, std::chrono::milliseconds poll);
  ~ChangeWatch();  // stop()
  ChangeWatch(const ChangeWatch&) = delete;
  ChangeWatch& operator=(const ChangeWatch&) = delete;

  // Calls `wake` once, when the log's last seq is known to be past `after`:
  // at once on the caller's thread if it already is, else on the watch's
  // thread, which `wake` must not block (post the work elsewhere). Returns
  // an id for cancel(); no call after stop().
  std::uint64_t notify_after(std::int64_t after, std::function<void()> wake);
  // Forgets a waiter; no effect when it was woken already.
  void cancel(std::uint64_t id);
  // Joins the thread and drops every waiter without waking it.
  void stop();

  std::size_t waiting() const;

 private:
  struct Waiter {
    std::int64_t after;
    std::function<void()> wake;
  };

  void run();
  void wake_past(std::int64_t head);

  db::Store& store_;
  const std::chrono::milliseconds poll_;
  mutable std::mutex mu_;
  std::condition_variable idle_;
  std::map<std::uint64_t, Waiter> waiters_;
  std::uint64_t next_id_ = 1;
  std::int64_t known_head_ = -1;  // the last seq last read, -1 before any
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace arscout::ingest
