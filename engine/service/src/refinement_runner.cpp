#include "refinement_runner.h"

#include <chrono>
#include <optional>

#include "phase.h"

namespace arscout::engine::service {

void RefinementRunner::run(const std::string& site, SiteJob& job, SiteQueue& q,
                           std::unique_lock<std::mutex>& lock) {
  const bool give_way = !board_.options.reconstruction.deterministic;
  if (too_soon(job, q)) {
    q.schedule.on(SiteEvent::kRefineTooSoon);
    return;
  }
  lock.unlock();
  bool dense_due = false;
  try {
    std::lock_guard publication(job.publication());
    const bool urgent = job.refinement_urgent();
    bool dense_busy = false;
    {
      std::lock_guard guard(board_.mutex);
      dense_busy = q.schedule.dense_busy();
    }
    if (!job.refinement_due() || (!urgent && dense_busy)) {
      lock.lock();
      return;
    }
    const Rounds rounds = run_rounds(site, job, q, urgent);
    dense_due = job.dense_due();
    lock.lock();
    if (rounds.written > 0)
      q.last_refinement = std::chrono::steady_clock::now();
    if (rounds.state_saved) board_.release_unsaved(q);
    board_.stats.increments += rounds.written;
    // A round that used up its iterations goes on in the next call (the
    // core bounds the rounds on one model), as does the adjustment that
    // registered captures or merged components make due; with dense phases
    // the lane's end asks for it, without them nothing else would.
    if ((rounds.again || (rounds.written > 0 && job.refinement_due())) &&
        !dense_due)
      q.schedule.on(SiteEvent::kRefineWanted);
  } catch (const std::exception& e) {
    if (lock.owns_lock()) lock.unlock();
    reset_job(job);
    board_.log("site " + site + ": refinement failed, will retry: " + e.what());
    lock.lock();
    board_.requeue_unsaved(q);
    return;
  }
  // The refined poses move the depth maps: the cloud follows them, unless
  // work arrived (its increment's dense phase does it then).
  if (dense_due && (!give_way || q.pending.empty()))
    dense_.start(site, job, lock);
}

// Registered waiting captures make the adjustment due: a deterministic run
// does it at once (the order must not depend on arrivals), the others
// after new work and the views' cloud. Called without the board's lock,
// holding publication().
RefinementRunner::Rounds RefinementRunner::run_rounds(const std::string& site,
                                                      SiteJob& job,
                                                      SiteQueue& q,
                                                      bool urgent) {
  const bool give_way = !board_.options.reconstruction.deterministic;
  Rounds rounds;
  Increment refined;
  do {
    RefinePhase round([&] {
      std::lock_guard guard(board_.mutex);
      return board_.stopping ||
             (give_way &&
              (!q.pending.empty() || (!urgent && q.schedule.dense_busy())));
    });
    refined = run_phase(round, job, &board_.phases.refine);
    if (!refined.ops.empty())
      committer_.commit(site, job, refined, std::nullopt);
    rounds.written += refined.model_written ? 1 : 0;
    rounds.state_saved = rounds.state_saved || refined.state_written;
  } while (refined.refine_again && !give_way);
  rounds.again = refined.refine_again;
  return rounds;
}

// A round due before the site's interval since its last one has passed,
// and not urgent.
bool RefinementRunner::too_soon(const SiteJob& job, const SiteQueue& q) const {
  const WorkerOptions& options = board_.options;
  if (options.refinement_interval.count() <= 0 ||
      options.reconstruction.deterministic || !job.refinement_due() ||
      job.refinement_urgent())
    return false;
  return std::chrono::steady_clock::now() - q.last_refinement <
         options.refinement_interval;
}

void RefinementRunner::wake_deferred() {
  const auto now = std::chrono::steady_clock::now();
  for (auto& [site, q] : board_.sites) {
    if (q.schedule.refinement() != RefinementState::kDeferred ||
        now - q.last_refinement < board_.options.refinement_interval)
      continue;
    q.schedule.on(SiteEvent::kRefineIntervalPassed);
    board_.make_ready(site, q);
  }
}

}  // namespace arscout::engine::service
