// Exports kept per site, model version, format and options: a model version
// never changes, so its LAS or 3D Tiles file is built once however many
// planners download it at the same moment (one build, the others wait for
// it), and is then sent from memory. Least recently used files are dropped
// past a total size. Thread-safe.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "arscout/viewer/exports.h"

namespace arscout::viewer {

class ExportCache {
 public:
  explicit ExportCache(std::size_t max_bytes);

  // The file under `key`, built by `build` in the first request's thread
  // (later requests for the same key wait for that build). An
  // exception from `build` reaches every request that waited, and the next
  // request builds again.
  std::shared_ptr<const ExportFile> get(
      const std::string& key, const std::function<ExportFile()>& build);

  std::int64_t builds() const;  // keys built (misses)
  std::int64_t hits() const;    // requests served from a built or pending key
  std::size_t bytes() const;    // held by built files

 private:
  using Future = std::shared_future<std::shared_ptr<const ExportFile>>;
  struct Entry {
    Future file;
    std::size_t bytes = 0;   // 0 while building
    std::uint64_t used = 0;  // recency
  };
  void keep_within_limit(const std::string& keep);

  const std::size_t max_bytes_;
  mutable std::mutex mutex_;
  std::map<std::string, Entry> entries_;
  std::uint64_t clock_ = 0;
  std::size_t bytes_ = 0;
  std::int64_t builds_ = 0, hits_ = 0;
};

}  // namespace arscout::viewer
