#include "site_merger.h"

#include <map>
#include <optional>
#include <stdexcept>

#include "arscout/db/store.h"
#include "phase.h"

namespace arscout::engine::service {

void SiteMerger::request(const std::string& site, SiteQueue& q,
                         const Work& work) {
  const std::string& other = work.capture;
  SiteQueue& qb = board_.sites[other];
  if (!board_.holds(site) || !board_.holds(other) || !q.merging_into.empty() ||
      !qb.merging_into.empty())
    return;
  qb.merging_into = site;
  board_.in_flight.insert(work.seq);
  q.merges.push_back(work);
  board_.log("site " + other + " meets site " + site + ": merging once idle");
  board_.make_ready(site, q);
}

void SiteMerger::run_merges(const std::string& site, SiteJob& job, SiteQueue& q,
                            std::unique_lock<std::mutex>& lock) {
  for (auto it = q.merges.begin(); it != q.merges.end();) {
    if (!board_.holds(it->capture)) {  // lost meanwhile
      drop(*it);
      it = q.merges.erase(it);
      continue;
    }
    if (!board_.sites[it->capture].schedule.lanes_idle()) {
      ++it;
      continue;
    }
    const Work w = *it;
    it = q.merges.erase(it);
    run_merge(site, job, w, lock);
    it = q.merges.begin();  // the lock was let go: look again
  }
}

void SiteMerger::drop(const Work& w) {
  board_.in_flight.erase(board_.in_flight.find(w.seq));
  SiteQueue& qb = board_.sites[w.capture];
  qb.merging_into.clear();
  board_.make_ready(w.capture, qb);
}

void SiteMerger::run_merge(const std::string& site, SiteJob& job, const Work& w,
                           std::unique_lock<std::mutex>& lock) {
  const std::string other = w.capture;
  board_.in_flight.erase(board_.in_flight.find(w.seq));
  SiteQueue& qb = board_.sites[other];
  qb.schedule.on(SiteEvent::kMergeHold);  // keeps its lanes out
  const std::shared_ptr<SiteJob> other_job = board_.job_for(other, qb);
  lock.unlock();
  bool merged = false, jobs_reset = false;
  try {
    commit_merge(site, other, job, *other_job);
    merged = true;
  } catch (const std::invalid_argument& e) {
    board_.log("site " + other + " meets site " + site +
               ", not merged: " + e.what());
  } catch (const std::exception& e) {
    reset_job(job);
    reset_job(*other_job);
    jobs_reset = true;
    reload_sites({site, other});
    board_.log("site " + other + " into " + site +
               ": merge failed: " + e.what());
  }
  lock.lock();
  qb.schedule.on(SiteEvent::kMergeRelease);
  qb.merging_into.clear();
  SiteQueue& q = board_.sites[site];
  if (jobs_reset) {
    board_.requeue_unsaved(q);
    board_.requeue_unsaved(qb);
  }
  if (merged) {
    take_over(site, q, qb);
    if (job.dense_due()) dense_.start(site, job, lock);
  } else {
    board_.make_ready(other, qb);
  }
  board_.changed.notify_all();
}

void SiteMerger::commit_merge(const std::string& site, const std::string& other,
                              SiteJob& job, SiteJob& other_job) {
  std::scoped_lock both(job.publication(), other_job.publication());
  MergePhase merge(other_job);
  Increment increment = run_phase(merge, job, nullptr);
  board_.directory.merge(other, site);
  documents::Site gone = SiteDirectory::to_document(
      *board_.directory.site(other), board_.directory.radius_m());
  gone.state = "merged";
  gone.engine = board_.options.name;
  db::WriteOp gone_op = committer_.site_put(other, gone);
  gone_op.expected_version.reset();  // gone: its name matters no more
  increment.ops.push_back(std::move(gone_op));
  committer_.commit(site, job, increment, std::nullopt);
}

void SiteMerger::take_over(const std::string& site, SiteQueue& q,
                           SiteQueue& qb) {
  // Both states are saved as one now.
  board_.release_unsaved(q);
  board_.release_unsaved(qb);
  // Its queued captures are this site's now.
  q.pending.insert(q.pending.end(), qb.pending.begin(), qb.pending.end());
  q.pending.insert(q.pending.end(), qb.deferred.begin(), qb.deferred.end());
  sort_by_seq(q.pending);
  qb.pending.clear();
  qb.deferred.clear();
  // So are the sites that were to grow into it.
  for (const Work& taken : qb.merges) {
    board_.sites[taken.capture].merging_into = site;
    q.merges.push_back(taken);
  }
  qb.merges.clear();
  qb.job.reset();
  ++board_.stats.sites_merged;
  q.schedule.set_refusing_only(false);
}

void SiteMerger::reload_sites(const std::vector<std::string>& ids) {
  std::map<std::string, db::Json> stored;
  for (const std::string& id : ids)
    if (auto doc = board_.store.get("/sites/" + id)) stored[id] = doc->attrs;
  board_.directory.load(stored);
}

}  // namespace arscout::engine::service
