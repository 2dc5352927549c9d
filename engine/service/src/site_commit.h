// Commits a site's increments: the increment's writes, the site document
// (with the name a person gave it kept) and, when given, the feed
// checkpoint, in one batch authored by the worker. The commit is the one
// point where a phase's result becomes the site's published version.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>

#include "arscout/db/store.h"
#include "arscout/documents/site.h"
#include "arscout/engine/service.h"
#include "site_directory.h"
#include "site_job.h"

namespace arscout::engine::service {

class SiteCommitter {
 public:
  SiteCommitter(db::Store& store, const WorkerOptions& options,
                SiteDirectory& directory)
      : store_(store), options_(options), directory_(directory) {}

  // Follows the increment's footprint in the directory and commits its
  // writes with the site document; then job.committed(). Retries a
  // conflict on the site document alone (a rename between the read and
  // the write) with the name read again. Throws what the store throws.
  // The caller holds job.publication().
  void commit(const std::string& site, SiteJob& job, Increment& increment,
              std::optional<std::int64_t> checkpoint);

  // The site document as the engine writes it, with the stored name kept,
  // expected at the version read.
  db::WriteOp site_put(const std::string& site, documents::Site doc);

 private:
  db::Store& store_;
  const WorkerOptions& options_;
  SiteDirectory& directory_;
};

// Sets increment.seconds to the time since `start` and appends it to the
// summary ("..., ready in 420 ms").
void append_ready_time(Increment& increment,
                       std::chrono::steady_clock::time_point start);

}  // namespace arscout::engine::service
