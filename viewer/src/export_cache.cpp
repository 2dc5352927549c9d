#include "export_cache.h"

#include <vector>

namespace arscout::viewer {

ExportCache::ExportCache(std::size_t max_bytes) : max_bytes_(max_bytes) {}

std::shared_ptr<const ExportFile> ExportCache::get(
    const std::string& key, const std::function<ExportFile()>& build) {
  std::promise<std::shared_ptr<const ExportFile>> promise;
  {
    std::unique_lock lock(mutex_);
    auto it = entries_.find(key);
    if (it != entries_.end()) {
      ++hits_;
      it->second.used = ++clock_;
      Future file = it->second.file;
      lock.unlock();
      return file.get();
    }
    ++builds_;
    entries_[key] = Entry{promise.get_future().share(), 0, ++clock_};
  }
  std::shared_ptr<const ExportFile> file;
  try {
    file = std::make_shared<const ExportFile>(build());
  } catch (...) {
    promise.set_exception(std::current_exception());
    std::lock_guard lock(mutex_);
    entries_.erase(key);
    throw;
  }
  promise.set_value(file);
  std::lock_guard lock(mutex_);
  auto it = entries_.find(key);
  if (it != entries_.end()) {
    it->second.bytes = file->bytes.size();
    bytes_ += it->second.bytes;
  }
  keep_within_limit(key);
  return file;
}

// Drops the least recently used built files until the rest fit, never the
// one just built (it is being sent) nor one still building.
void ExportCache::keep_within_limit(const std::string& keep) {
  while (bytes_ > max_bytes_) {
    auto oldest = entries_.end();
    for (auto it = entries_.begin(); it != entries_.end(); ++it)
      if (it->first != keep && it->second.bytes > 0 &&
          (oldest == entries_.end() || it->second.used < oldest->second.used))
        oldest = it;
    if (oldest == entries_.end()) {  // only `keep` is left: it goes too
      auto self = entries_.find(keep);
      if (self != entries_.end() && self->second.bytes > 0) {
        bytes_ -= self->second.bytes;
        entries_.erase(self);
      }
      return;
    }
    bytes_ -= oldest->second.bytes;
    entries_.erase(oldest);
  }
}

std::int64_t ExportCache::builds() const {
  std::lock_guard lock(mutex_);
  return builds_;
}

std::int64_t ExportCache::hits() const {
  std::lock_guard lock(mutex_);
  return hits_;
}

std::size_t ExportCache::bytes() const {
  std::lock_guard lock(mutex_);
  return bytes_;
}

}  // namespace arscout::viewer
