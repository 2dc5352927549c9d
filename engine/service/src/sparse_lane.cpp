#include "sparse_lane.h"

#include <algorithm>
#include <chrono>
#include <thread>

#include "arscout/db/errors.h"
#include "arscout/db/store.h"
#include "arscout/documents/capture.h"
#include "fair_turns.h"
#include "phase.h"

namespace arscout::engine::service {
namespace {

// Times one capture's increment may fail in the engine before the capture
// is rejected (after_engine_fault).
constexpr int kEngineFailures = 2;

}  // namespace

void SparseLane::run() {
  std::unique_lock lock(board_.mutex);
  while (true) {
    board_.changed.wait_for(lock, std::chrono::seconds(1), [&] {
      return board_.stopping || !board_.ready.empty();
    });
    if (board_.stopping) return;
    refinement_.wake_deferred();
    if (board_.ready.empty()) {
      saver_.save_idle_states(lock);
      saver_.save_idle_checkpoint(lock);
      continue;
    }
    const std::string site = board_.ready.pop();
    SiteQueue& q = board_.sites[site];
    if (!board_.holds(site)) {
      WorkerBoard::defer(q);
      continue;
    }
    if (!q.merging_into.empty()) continue;  // waits to be taken in
    if (board_.directory.current(site) != site) continue;  // taken in already
    run_turn(site, q, lock);
  }
}

// Deterministic runs take one capture per increment: folding whatever
// arrived meanwhile depends on timing, and so would the dense phase's
// choice of views.
std::vector<Work> SparseLane::take_work(SiteQueue& q) const {
  const WorkerOptions& options = board_.options;
  const bool one = options.reconstruction.deterministic || q.one_at_a_time;
  return take_in_turns(q.pending, one ? 1
                                      : static_cast<std::size_t>(std::max(
                                            1, options.increment_captures)));
}

void SparseLane::run_turn(const std::string& site, SiteQueue& q,
                          std::unique_lock<std::mutex>& lock) {
  const bool catch_up = q.schedule.dense_catch_up();
  q.schedule.on(SiteEvent::kSparseBegin);
  const std::vector<Work> work = take_work(q);
  const std::int64_t through =
      work.empty() ? 0 : settled_through(work, q.pending);
  const std::shared_ptr<SiteJob> held_job = board_.job_for(site, q);
  SiteJob& job = *held_job;
  // A dense phase waiting to publish goes first: the lanes take turns.
  board_.changed.wait(
      lock, [&] { return board_.stopping || !q.schedule.dense_turn(); });
  merger_.run_merges(site, job, q, lock);
  bool ok = true;  // nothing to add: a refinement that gave way resumes
  std::string engine_fault;
  if (!work.empty() || catch_up) {
    lock.unlock();
    ok = run_increment(site, job, q, work, through, lock, &engine_fault);
  }
  if (ok && !work.empty()) q.one_at_a_time = false;
  if (ok && board_.holds(site) &&
      (q.pending.empty() || board_.options.reconstruction.deterministic))
    refinement_.run(site, job, q, lock);
  q.schedule.on(SiteEvent::kSparseEnd);
  if (!ok) {
    q.pending.insert(q.pending.begin(), work.begin(), work.end());
    sort_by_seq(q.pending);
    if (!engine_fault.empty()) after_engine_fault(q, work, engine_fault);
  }
  if (!ok || q.schedule.dense_catch_up()) {
    // After a pause: the store may be briefly unavailable (a restarting
    // server).
    lock.unlock();
    std::this_thread::sleep_for(std::chrono::seconds(1));
    lock.lock();
  }
  if (board_.holds(site)) {
    board_.make_ready(site, q);
  } else {
    WorkerBoard::defer(q);
    q.job.reset();
  }
  board_.wake_merge(q);
  board_.changed.notify_all();
}

bool SparseLane::run_increment(const std::string& site, SiteJob& job,
                               SiteQueue& q, const std::vector<Work>& work,
                               std::int64_t through,
                               std::unique_lock<std::mutex>& lock,
                               std::string* engine_fault) {
  bool dense_due = false;
  try {
    std::unique_lock publication(job.publication());
    const bool save_state = saver_.state_save_due(job);
    SparsePhase sparse(work, through, save_state);
    Increment increment = run_phase(sparse, job, &board_.phases.sparse);
    lock.lock();
    std::vector<Work> done;
    if (increment.state_written) {
      done = work;
      done.insert(done.end(), q.unsaved.begin(), q.unsaved.end());
    }
    const std::int64_t checkpoint = board_.checkpoint_without(done);
    lock.unlock();
    committer_.commit(site, job, increment, checkpoint);
    dense_due = job.dense_due();
    publication.unlock();
    lock.lock();
    q.unsaved.insert(q.unsaved.end(), work.begin(), work.end());
    if (increment.state_written) board_.release_unsaved(q);
    board_.checkpoint_saved(checkpoint);
    board_.stats.increments += increment.model_written ? 1 : 0;
    q.schedule.set_refusing_only(false);  // its views are to sweep
  } catch (const std::exception& e) {
    // The store's failures pass; the engine's would repeat on these photos.
    const bool in_store = dynamic_cast<const db::StoreError*>(&e) != nullptr;
    if (lock.owns_lock()) lock.unlock();
    reset_job(job);
    board_.log("site " + site + ": increment failed" +
               (in_store ? ", will retry: " : " in the engine: ") + e.what());
    lock.lock();
    board_.requeue_unsaved(q);
    ++board_.stats.failures;
    if (!in_store) *engine_fault = e.what();
    return false;
  }
  if (dense_due) dense_.start(site, job, lock);
  return true;
}

// Called with the lock held.
void SparseLane::after_engine_fault(SiteQueue& q, const std::vector<Work>& work,
                                    const std::string& what) {
  q.one_at_a_time = true;
  if (work.size() != 1 ||
      ++q.engine_failures[work.front().capture] < kEngineFailures)
    return;
  const Work& w = work.front();
  try {
    db::WriteOp op = db::WriteOp::patch(
        "/captures/" + w.capture,
        documents::status_patch(documents::CaptureStatus::kRejected,
                                "the engine failed on this photo " +
                                    std::to_string(kEngineFailures) +
                                    " times: " + what));
    op.author = board_.options.name;
    board_.store.batch({op});
  } catch (const std::exception& e) {
    board_.log("capture " + w.capture + ": rejecting it failed: " + e.what());
    return;  // retried: the next failure tries again
  }
  board_.log("capture " + w.capture + ": rejected, the engine failed on it");
  q.engine_failures.erase(w.capture);
  std::erase_if(q.pending, [&](const Work& p) { return p.seq == w.seq; });
  board_.in_flight.erase(board_.in_flight.find(w.seq));
}

}  // namespace arscout::engine::service
