// Whether the store answers, for /healthz: read by a thread of its own
// every 250 ms once started, so that a health check never waits for a
// store connection behind a crowd of requests (160 connections at once
// held the first /healthz for 134-272 ms while their token lookups opened
// new SQLite readers). Without the thread (an Api alone, as tests build
// one) each check reads the store itself. Thread-safe.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <string>
#include <thread>

#include "arscout/db/store.h"

namespace arscout::ingest {

class StoreHealth {
 public:
  explicit StoreHealth(db::Store& store) : store_(store) {}
  ~StoreHealth() { stop(); }
  StoreHealth(const StoreHealth&) = delete;
  StoreHealth& operator=(const StoreHealth&) = delete;

  struct Reading {
    bool ok = false;
    std::int64_t last_seq = 0;
    std::string error;  // why not ok
  };

  // Reads the store every `every` on a thread of its own until stop().
  void start(std::chrono::milliseconds every);
  void stop();
  // The thread's last reading when it is at most 4 periods old; a stale
  // one (the store hangs) is not ok. Without the thread: a reading now.
  Reading check();

 private:
  Reading read_now();

  db::Store& store_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool running_ = false, stopping_ = false;
  std::chrono::milliseconds every_{250};
  Reading last_;
  std::chrono::steady_clock::time_point last_at_{};
  std::thread thread_;
};

}  // namespace arscout::ingest
