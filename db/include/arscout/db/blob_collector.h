// Garbage collection of blobs that no document refers to, run by itself on
// a thread of its own (`arscout serve` and `arscout engine` start one;
// docs/service.md, "Storage"): every `interval` it calls
// Store::collect_garbage(min_age) and counts what it removed, for /metrics.
//
// Safe against concurrent writers: the store orders a collection against
// document writes (a blob is never removed between a writer's check that it
// exists and its reference), and a blob stored again (put_blob of bytes it
// holds) counts as new for the grace period, so a writer that stores a blob
// and refers to it within `min_age` never finds it gone.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <string>
#include <thread>

#include "arscout/db/store.h"

namespace arscout::db {

struct BlobCollectorOptions {
  std::chrono::seconds interval{600};  // between collections; 0: never
  std::chrono::seconds min_age{3600};  // the grace period of a new blob
};

struct BlobCollectorStats {
  std::int64_t runs = 0;
  std::int64_t failures = 0;       // collections the store refused
  std::int64_t blobs_removed = 0;  // in all runs
  // Bytes the store's blobs shrank by across the runs (writers adding
  // blobs meanwhile make this a lower bound).
  std::int64_t bytes_removed = 0;
  std::int64_t blobs = 0;  // the store's blobs and bytes after the last run
  std::int64_t blob_bytes = 0;
  double last_seconds = 0;  // how long the last run took
};

class BlobCollector {
 public:
  BlobCollector(Store& store, BlobCollectorOptions options);
  ~BlobCollector();  // stops
  BlobCollector(const BlobCollector&) = delete;
  BlobCollector& operator=(const BlobCollector&) = delete;

  // Collects every `interval` (the first after one interval) until stop().
  void start();
  void stop();
  // One collection now, on the caller's thread; returns blobs removed.
  // Throws StoreError when the store cannot collect (counted as a failure).
  std::size_t collect_now();
  BlobCollectorStats stats() const;
  // The stats in the Prometheus text format (arscout_gc_*), for /metrics.
  std::string metrics() const;

 private:
  void run();

  Store& store_;
  const BlobCollectorOptions options_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;
  BlobCollectorStats stats_;
  std::thread thread_;
};

}  // namespace arscout::db
