#include "worker_board.h"

#include <algorithm>

namespace arscout::engine::service {

void WorkerBoard::log(const std::string& line) const {
  if (options.progress) options.progress(line);
}

bool WorkerBoard::dense_lanes() const {
  return options.dense && !options.reconstruction.deterministic;
}

bool WorkerBoard::merge_ready(const SiteQueue& q) {
  return std::any_of(q.merges.begin(), q.merges.end(), [&](const Work& w) {
    return sites[w.capture].schedule.lanes_idle();
  });
}

void WorkerBoard::make_ready(const std::string& site, SiteQueue& q) {
  // A site promised to another waits for it, its work kept for it.
  if (q.schedule.sparse_busy() || ready.contains(site) ||
      !q.merging_into.empty() ||
      (q.pending.empty() && !q.schedule.sparse_due() && !merge_ready(q)))
    return;
  ready.push(site);
}

void WorkerBoard::wake_merge(const SiteQueue& q) {
  if (q.merging_into.empty()) return;
  make_ready(q.merging_into, sites[q.merging_into]);
}

std::shared_ptr<SiteJob> WorkerBoard::job_for(const std::string& site,
                                              SiteQueue& q) {
  if (!q.job) q.job = std::make_shared<SiteJob>(site, store, options, preparer);
  return q.job;
}

void WorkerBoard::defer(SiteQueue& q) {
  q.deferred.insert(q.deferred.end(), q.pending.begin(), q.pending.end());
  q.deferred.insert(q.deferred.end(), q.unsaved.begin(), q.unsaved.end());
  q.pending.clear();
  q.unsaved.clear();
  sort_by_seq(q.deferred);
}

void WorkerBoard::gain(const std::string& site) {
  SiteQueue& q = sites[site];
  q.pending.insert(q.pending.end(), q.deferred.begin(), q.deferred.end());
  q.deferred.clear();
  sort_by_seq(q.pending);
  make_ready(site, q);
  changed.notify_all();
}

void WorkerBoard::settle(const std::string& site, std::int64_t through_seq) {
  SiteQueue& q = sites[site];
  while (!q.deferred.empty() && q.deferred.front().seq <= through_seq) {
    in_flight.erase(in_flight.find(q.deferred.front().seq));
    q.deferred.pop_front();
  }
  changed.notify_all();
}

void WorkerBoard::release_unsaved(SiteQueue& q) {
  for (const Work& w : q.unsaved) in_flight.erase(in_flight.find(w.seq));
  q.unsaved.clear();
}

void WorkerBoard::requeue_unsaved(SiteQueue& q) {
  if (q.unsaved.empty()) return;
  q.pending.insert(q.pending.end(), q.unsaved.begin(), q.unsaved.end());
  q.unsaved.clear();
  sort_by_seq(q.pending);
}

std::int64_t WorkerBoard::checkpoint_without(
    const std::vector<Work>& done) const {
  std::multiset<std::int64_t> others = in_flight;
  for (const Work& w : done) others.erase(others.find(w.seq));
  return others.empty() ? last_placed : *others.begin() - 1;
}

void WorkerBoard::checkpoint_saved(std::int64_t checkpoint) {
  saved_checkpoint = std::max(saved_checkpoint, checkpoint);
  stats.checkpoint = saved_checkpoint;
}

void reset_job(SiteJob& job) {
  std::lock_guard publication(job.publication());
  job.reset();
}

void sort_by_seq(std::deque<Work>& work) {
  std::sort(work.begin(), work.end(),
            [](const Work& a, const Work& b) { return a.seq < b.seq; });
}

}  // namespace arscout::engine::service
