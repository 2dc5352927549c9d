// Blobs stored on a thread of their own. A capture's features (about 2 MB,
// stored once each) are needed only when the engine state that refers to
// them is saved; writing them there put every capture since the last save
// (40 of them at four scouts' pace, 80 MB) on one increment's latency
// path. The increment that extracts them hands them here instead, and the
// save waits only for what is not written yet.
#pragma once

#include <deque>
#include <future>
#include <mutex>
#include <string>
#include <thread>
#include <utility>

namespace arscout::db {
class Store;
}

namespace arscout::engine::service {

class BlobWriter {
 public:
  explicit BlobWriter(db::Store& store);
  // Waits for the blob being written; blobs still queued are not written
  // (their futures report a broken promise).
  ~BlobWriter();
  BlobWriter(const BlobWriter&) = delete;
  BlobWriter& operator=(const BlobWriter&) = delete;

  // Queues `bytes`; the future gives their SHA-256 once stored, or the
  // store's error. Blobs are written in the order given, by one thread
  // that runs only while there is work.
  std::shared_future<std::string> put(std::string bytes);

 private:
  void drain();

  db::Store& store_;
  std::mutex mutex_;
  std::deque<std::pair<std::string, std::promise<std::string>>> queue_;
  std::thread thread_;
  bool running_ = false;
  bool stopping_ = false;
};

}  // namespace arscout::engine::service
