// A site's sparse lane: a pool thread takes the next ready site and runs
// one increment of it, folding in everything queued for it meanwhile (in
// turns between scouts), after any merge into it whose other site is idle;
// then its refinement while nothing else waits. One site's sparse lane runs
// on one thread at a time (SparseState::kRunning).
//
// Failures: the store's pass (the work is requeued and retried after a
// pause); the engine's would repeat on the same photos, so its captures are
// retried one at a time and one that fails alone kEngineFailures times is
// rejected with the error: one photo never holds its site for good.
#pragma once

#include <cstdint>
#include <mutex>
#include <string>
#include <vector>

#include "dense_lane.h"
#include "refinement_runner.h"
#include "site_commit.h"
#include "site_merger.h"
#include "state_saver.h"
#include "worker_board.h"

namespace arscout::engine::service {

class SparseLane {
 public:
  SparseLane(WorkerBoard& board, SiteCommitter& committer, DenseLane& dense,
             SiteMerger& merger, RefinementRunner& refinement,
             StateSaver& saver)
      : board_(board),
        committer_(committer),
        dense_(dense),
        merger_(merger),
        refinement_(refinement),
        saver_(saver) {}

  // A pool thread: runs ready sites until the board stops; saves quiet
  // sites' states and the checkpoint while none is ready.
  void run();

 private:
  // Runs the site's turn: merges, its increment, its refinement. Called
  // and returns with `lock` held.
  void run_turn(const std::string& site, SiteQueue& q,
                std::unique_lock<std::mutex>& lock);
  // One increment: the sparse phase, committed with the checkpoint, then
  // its dense phase started. False, with the lock held, when the sparse
  // phase failed; `engine_fault` then gets the error when the engine (not
  // the store) failed. Called without the lock; returns with it.
  bool run_increment(const std::string& site, SiteJob& job, SiteQueue& q,
                     const std::vector<Work>& work, std::int64_t through,
                     std::unique_lock<std::mutex>& lock,
                     std::string* engine_fault);
  void after_engine_fault(SiteQueue& q, const std::vector<Work>& work,
                          const std::string& what);
  std::vector<Work> take_work(SiteQueue& q) const;

  WorkerBoard& board_;
  SiteCommitter& committer_;
  DenseLane& dense_;
  SiteMerger& merger_;
  RefinementRunner& refinement_;
  StateSaver& saver_;
};

}  // namespace arscout::engine::service
