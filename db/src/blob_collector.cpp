#include "arscout/db/blob_collector.h"

#include <spdlog/spdlog.h>

#include <sstream>

namespace arscout::db {

BlobCollector::BlobCollector(Store& store, BlobCollectorOptions options)
    : store_(store), options_(options) {}

BlobCollector::~BlobCollector() { stop(); }

void BlobCollector::start() {
  if (thread_.joinable() || options_.interval.count() <= 0) return;
  thread_ = std::thread([this] { run(); });
}

void BlobCollector::stop() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void BlobCollector::run() {
  std::unique_lock lock(mutex_);
  while (!wake_.wait_for(lock, options_.interval, [&] { return stopping_; })) {
    lock.unlock();
    try {
      collect_now();
    } catch (const StoreError& e) {  // the next run tries again
      spdlog::warn("event=blob_gc_failed error=\"{}\"", e.what());
    }
    lock.lock();
  }
}

std::size_t BlobCollector::collect_now() {
  const auto started = std::chrono::steady_clock::now();
  std::size_t removed = 0;
  StoreStats before, after;
  try {
    before = store_.stats();
    removed = store_.collect_garbage(options_.min_age);
    after = store_.stats();
  } catch (const StoreError&) {
    std::lock_guard lock(mutex_);
    ++stats_.runs;
    ++stats_.failures;
    throw;
  }
  std::lock_guard lock(mutex_);
  ++stats_.runs;
  stats_.blobs_removed += static_cast<std::int64_t>(removed);
  stats_.bytes_removed +=
      std::max<std::int64_t>(0, before.blob_bytes - after.blob_bytes);
  stats_.blobs = after.blobs;
  stats_.blob_bytes = after.blob_bytes;
  stats_.last_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started)
          .count();
  return removed;
}

BlobCollectorStats BlobCollector::stats() const {
  std::lock_guard lock(mutex_);
  return stats_;
}

std::string BlobCollector::metrics() const {
  const BlobCollectorStats s = stats();
  std::ostringstream out;
  const auto metric = [&](const char* name, const char* type, const char* help,
                          auto value) {
    out << "# HELP " << name << ' ' << help << "\n# TYPE " << name << ' '
        << type << '\n'
        << name << ' ' << value << '\n';
  };
  metric("arscout_gc_runs_total", "counter",
         "Garbage collections of unreferenced blobs run.", s.runs);
  metric("arscout_gc_failures_total", "counter",
         "Garbage collections the store refused.", s.failures);
  metric("arscout_gc_blobs_removed_total", "counter",
         "Unreferenced blobs removed.", s.blobs_removed);
  metric("arscout_gc_bytes_removed_total", "counter",
         "Bytes the stored blobs shrank by in collections.", s.bytes_removed);
  metric("arscout_store_blobs", "gauge",
         "Blobs stored after the last collection.", s.blobs);
  metric("arscout_store_blob_bytes", "gauge",
         "Bytes of blobs stored after the last collection.", s.blob_bytes);
  metric("arscout_gc_last_seconds", "gauge",
         "How long the last collection took.", s.last_seconds);
  return out.str();
}

}  // namespace arscout::db
