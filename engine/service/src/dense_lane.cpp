#include "dense_lane.h"

#include <chrono>
#include <optional>

#include "phase.h"
#include "thread_priority.h"

namespace arscout::engine::service {

void DenseLane::start(const std::string& site, SiteJob& job,
                      std::unique_lock<std::mutex>& lock) {
  if (!board_.dense_lanes()) {
    run_inline(site, job, lock);
    return;
  }
  SiteQueue& q = board_.sites[site];
  if (q.schedule.dense() != DenseState::kIdle) return;
  q.schedule.on(SiteEvent::kDenseDue);
  board_.dense_ready.push_back(site);
  board_.changed.notify_all();
}

void DenseLane::run_inline(const std::string& site, SiteJob& job,
                           std::unique_lock<std::mutex>& lock) {
  lock.unlock();
  try {
    std::lock_guard publication(job.publication());
    DensePhase phase;
    Increment dense = run_phase(phase, job, &board_.phases.dense);
    if (!dense.ops.empty()) committer_.commit(site, job, dense, std::nullopt);
    lock.lock();
    board_.stats.increments += dense.model_written ? 1 : 0;
  } catch (const std::exception& e) {
    failed(site, job, lock, e);
  }
}

void DenseLane::failed(const std::string& site, SiteJob& job,
                       std::unique_lock<std::mutex>& lock,
                       const std::exception& e) {
  if (lock.owns_lock()) lock.unlock();
  reset_job(job);
  board_.log("site " + site +
             ": dense phase failed, will catch up: " + e.what());
  lock.lock();
  SiteQueue& q = board_.sites[site];
  board_.requeue_unsaved(q);
  q.schedule.on(SiteEvent::kDenseFailed);
  ++board_.stats.failures;
}

void DenseLane::run() {
  std::unique_lock lock(board_.mutex);
  while (true) {
    board_.changed.wait(
        lock, [&] { return board_.stopping || !board_.dense_ready.empty(); });
    if (board_.stopping) return;
    const std::string site = board_.dense_ready.front();
    board_.dense_ready.pop_front();
    SiteQueue& q = board_.sites[site];
    if (!board_.holds(site) || !q.job || !q.merging_into.empty()) {
      q.schedule.on(SiteEvent::kDenseSkipped);
      board_.wake_merge(q);  // a site being merged is swept there
      continue;
    }
    const std::shared_ptr<SiteJob> job = q.job;
    q.schedule.on(SiteEvent::kDenseTaken);
    lock.unlock();
    try {
      const End end = sweep_and_publish(site, q, *job);
      lock.lock();
      finish(site, q, *job, end, lock);
    } catch (const std::exception& e) {
      failed(site, *job, lock, e);  // the lane ends: kDenseFailed
      finish(site, q, *job, End{}, lock);
    }
    board_.changed.notify_all();
  }
}

void DenseLane::finish(const std::string& site, SiteQueue& q, SiteJob& job,
                       const End& end, std::unique_lock<std::mutex>& lock) {
  if (q.schedule.dense_running()) q.schedule.on(SiteEvent::kDenseEnded);
  q.schedule.set_refusing_only(end.refusing_only);
  board_.wake_merge(q);
  if (end.dense_due) start(site, job, lock);
  // A refinement that gave way to this lane resumes, unless work came.
  if (end.refinement_due && q.pending.empty())
    q.schedule.on(SiteEvent::kRefineWanted);
  else
    q.schedule.on(SiteEvent::kRefineDropped);
  if (q.schedule.sparse_due()) board_.make_ready(site, q);
}

DenseLane::End DenseLane::sweep_and_publish(const std::string& site,
                                            SiteQueue& q, SiteJob& job) {
  const auto start = std::chrono::steady_clock::now();
  std::optional<DenseTask> task;
  {
    std::lock_guard publication(job.publication());
    on(q, SiteEvent::kDenseBegun);
    task = job.begin_dense();
  }
  if (!task) return {};
  // OpenCV's shared pool runs at full priority, and while a sweep holds it
  // the sparse lane's own parallel calls (SIFT) run serially: the sweep
  // takes the pool only while the sparse lane is idle, asked again every
  // quarter sweep or so (a photo may arrive at any moment).
  task->parallel = [this, &q] {
    std::lock_guard guard(board_.mutex);
    return !q.schedule.sparse_busy() && q.pending.empty();
  };
  // The sweep yields the CPU to the sparse lane, whose latency a scout
  // waits on; the publication after it does not, as the sparse lane waits
  // for it.
  run_at_lane_priority(BackgroundLane::kDense,
                       [&] { job.compute_dense(*task); });
  on(q, SiteEvent::kDenseSwept);  // a refinement gives way too
  std::lock_guard publication(job.publication());
  // Timed from the lane's start: the sweep is the phase's longest part.
  DensePublication publication_phase(*task);
  Increment dense = publication_phase.run(job);
  append_ready_time(dense, start);
  board_.phases.dense.observe(dense.seconds);
  if (!dense.ops.empty()) committer_.commit(site, job, dense, std::nullopt);
  std::lock_guard guard(board_.mutex);
  board_.stats.increments += dense.model_written ? 1 : 0;
  const bool refusing_only =
      task->update.new_depth_maps.empty() && task->update.deferred_views == 0;
  return {job.dense_due(), job.refinement_due(), refusing_only};
}

void DenseLane::on(SiteQueue& q, SiteEvent event) {
  std::lock_guard guard(board_.mutex);
  q.schedule.on(event);
  board_.changed.notify_all();
}

}  // namespace arscout::engine::service
