#include "state_saver.h"

#include "arscout/db/store.h"
#include "phase.h"

namespace arscout::engine::service {

bool StateSaver::state_save_due(const SiteJob& job) const {
  const WorkerOptions& options = board_.options;
  if (options.reconstruction.deterministic ||
      options.state_interval.count() <= 0)
    return true;
  return job.seconds_state_unsaved() * 1000 >=
         static_cast<double>(options.state_interval.count());
}

void StateSaver::save_idle_states(std::unique_lock<std::mutex>& lock) {
  for (auto& [site, q] : board_.sites) {
    if (q.unsaved.empty() || q.schedule.sparse_busy() ||
        board_.ready.contains(site) || !q.pending.empty() ||
        q.schedule.dense_turn() || !q.job || !board_.holds(site) ||
        q.job->seconds_since_commit() * 1000 <
            static_cast<double>(board_.options.quiet_save_after.count()))
      continue;
    save_state(site, q, lock);
    return;  // the lock was let go: the next quiet second does the rest
  }
}

void StateSaver::save_state(const std::string& site, SiteQueue& q,
                            std::unique_lock<std::mutex>& lock) {
  q.schedule.on(SiteEvent::kSaveBegin);
  const std::shared_ptr<SiteJob> job = q.job;
  lock.unlock();
  bool saved = false;
  try {
    std::lock_guard publication(job->publication());
    SaveStatePhase save;
    Increment increment = run_phase(save, *job, nullptr);
    if (!increment.ops.empty()) {
      lock.lock();
      const std::int64_t checkpoint = board_.checkpoint_without(q.unsaved);
      lock.unlock();
      committer_.commit(site, *job, increment, checkpoint);
      saved = true;
      lock.lock();
      board_.checkpoint_saved(checkpoint);
      lock.unlock();
    }
  } catch (const std::exception& e) {
    if (lock.owns_lock()) lock.unlock();
    board_.log("site " + site +
               ": engine state not saved, will retry: " + e.what());
  }
  lock.lock();
  if (saved) board_.release_unsaved(q);
  q.schedule.on(SiteEvent::kSaveEnd);
  board_.make_ready(site, q);
  board_.changed.notify_all();
}

void StateSaver::save_idle_checkpoint(std::unique_lock<std::mutex>& lock) {
  if (!board_.in_flight.empty() ||
      board_.last_placed <= board_.saved_checkpoint)
    return;
  const std::int64_t seq = board_.last_placed;
  lock.unlock();
  try {
    db::WriteOp op = db::WriteOp::put("/checkpoints/" + board_.options.name,
                                      "checkpoint", db::Json{{"seq", seq}});
    op.author = board_.options.name;
    board_.store.batch({op});
    lock.lock();
    board_.checkpoint_saved(seq);
  } catch (const std::exception& e) {
    board_.log(std::string("checkpoint not saved: ") + e.what());
    lock.lock();
  }
}

}  // namespace arscout::engine::service
