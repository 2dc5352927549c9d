#include "site_commit.h"

#include "arscout/db/errors.h"

namespace arscout::engine::service {

db::WriteOp SiteCommitter::site_put(const std::string& site,
                                    documents::Site doc) {
  const auto stored = store_.get("/sites/" + site);
  if (stored) doc.name = stored->attrs.value("name", doc.name);
  return db::WriteOp::put("/sites/" + site, "site", documents::to_json(doc),
                          stored ? stored->version : 0);
}

void SiteCommitter::commit(const std::string& site, SiteJob& job,
                           Increment& increment,
                           std::optional<std::int64_t> checkpoint) {
  directory_.follow(site, increment.footprint, increment.settled);
  const auto info = directory_.site(site);
  documents::Site doc =
      SiteDirectory::to_document(*info, directory_.radius_m());
  doc.registered = static_cast<int>(job.registered());
  doc.model_version = job.model_version() + (increment.model_written ? 1 : 0);
  doc.state = job.registered() > 0 ? "modelled" : "waiting";
  doc.engine = options_.name;
  const std::size_t site_op = increment.ops.size();
  increment.ops.push_back(site_put(site, doc));
  if (checkpoint)
    increment.ops.push_back(db::WriteOp::put("/checkpoints/" + options_.name,
                                             "checkpoint",
                                             db::Json{{"seq", *checkpoint}}));
  for (db::WriteOp& op : increment.ops) op.author = options_.name;
  const auto start = std::chrono::steady_clock::now();
  for (int attempt = 1;; ++attempt) {
    try {
      store_.batch(increment.ops);
      break;
    } catch (const db::ConflictError& e) {
      // Renamed (PATCH /v1/sites/{id}) between the read and the write: the
      // name read again, the rest as it was.
      if (e.path() != "/sites/" + site || attempt == 3) throw;
      increment.ops[site_op] = site_put(site, doc);
      increment.ops[site_op].author = options_.name;
    }
  }
  job.committed();
  if (options_.progress)
    options_.progress(increment.summary + ", committed in " +
                      std::to_string(static_cast<int>(
                          std::chrono::duration<double, std::milli>(
                              std::chrono::steady_clock::now() - start)
                              .count())) +
                      " ms");
}

void append_ready_time(Increment& increment,
                       std::chrono::steady_clock::time_point start) {
  increment.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
          .count();
  increment.summary +=
      ", ready in " +
      std::to_string(static_cast<int>(increment.seconds * 1000)) + " ms";
}

}  // namespace arscout::engine::service
