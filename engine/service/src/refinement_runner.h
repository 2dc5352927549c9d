// A site's global refinement, run in its sparse lane while it has no work
// waiting. It gives way (after the solver iteration under way) as soon as
// work arrives or the dense lane has work (SiteSchedule::dense_busy),
// unless a merge or a loop closure made it urgent, and publishes what it
// reached as a model version. Deterministic runs let it finish, so that a
// replay gives the same models however fast it arrives. A round due sooner
// than WorkerOptions::refinement_interval after the last is deferred
// (RefinementState::kDeferred) and woken once the interval has passed.
#pragma once

#include <mutex>
#include <string>

#include "dense_lane.h"
#include "site_commit.h"
#include "worker_board.h"

namespace arscout::engine::service {

class RefinementRunner {
 public:
  RefinementRunner(WorkerBoard& board, SiteCommitter& committer,
                   DenseLane& dense)
      : board_(board), committer_(committer), dense_(dense) {}

  // Runs the site's refinement if due. Called and returns with `lock`
  // (the board's) held; `site`'s sparse lane is the caller's.
  void run(const std::string& site, SiteJob& job, SiteQueue& q,
           std::unique_lock<std::mutex>& lock);
  // Deferred refinements whose interval has passed are made ready. Called
  // with the lock held.
  void wake_deferred();

 private:
  bool too_soon(const SiteJob& job, const SiteQueue& q) const;
  // The rounds of one call, each committed; whether any wrote a model.
  struct Rounds {
    int written = 0;
    bool state_saved = false;
    bool again = false;  // the last round used up its iterations
  };
  Rounds run_rounds(const std::string& site, SiteJob& job, SiteQueue& q,
                    bool urgent);

  WorkerBoard& board_;
  SiteCommitter& committer_;
  DenseLane& dense_;
};

}  // namespace arscout::engine::service
