#include "blob_writer.h"

#include <exception>

#include "arscout/db/store.h"

namespace arscout::engine::service {

BlobWriter::BlobWriter(db::Store& store) : store_(store) {}

BlobWriter::~BlobWriter() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  if (thread_.joinable()) thread_.join();
}

std::shared_future<std::string> BlobWriter::put(std::string bytes) {
  std::promise<std::string> promise;
  std::shared_future<std::string> sha = promise.get_future().share();
  std::lock_guard lock(mutex_);
  queue_.emplace_back(std::move(bytes), std::move(promise));
  if (!running_) {
    // The last thread found the queue empty and is ending (or has ended).
    if (thread_.joinable()) thread_.join();
    running_ = true;
    thread_ = std::thread([this] { drain(); });
  }
  return sha;
}

void BlobWriter::drain() {
  for (;;) {
    std::pair<std::string, std::promise<std::string>> next;
    {
      std::lock_guard lock(mutex_);
      if (queue_.empty() || stopping_) {
        queue_.clear();
        running_ = false;
        return;
      }
      next = std::move(queue_.front());
      queue_.pop_front();
    }
    try {
      next.second.set_value(store_.put_blob(next.first));
    } catch (...) {
      next.second.set_exception(std::current_exception());
    }
  }
}

}  // namespace arscout::engine::service
