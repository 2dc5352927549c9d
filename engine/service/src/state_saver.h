// Saves what quiet moments allow: the engine state of a site whose
// committed work is not in a saved state yet (WorkerOptions::state_interval
// lets busy sites leave it unsaved), so that the checkpoint can pass that
// work, and the checkpoint itself when nothing is in flight.
#pragma once

#include <mutex>
#include <string>

#include "site_commit.h"
#include "worker_board.h"

namespace arscout::engine::service {

class StateSaver {
 public:
  StateSaver(WorkerBoard& board, SiteCommitter& committer)
      : board_(board), committer_(committer) {}

  // Whether the next increment of `job` writes the engine state: always
  // in deterministic runs, else once its unsaved work is state_interval
  // old (and when the site goes quiet, save_idle_states). No lock needed.
  bool state_save_due(const SiteJob& job) const;
  // Saves the engine state of one quiet site with unsaved work (no phase
  // running, queued or waiting for its turn, nothing committed for
  // WorkerOptions::quiet_save_after); the next quiet second does the
  // next. Called and returns with `lock` (the board's) held.
  void save_idle_states(std::unique_lock<std::mutex>& lock);
  // With nothing in flight the feed position moves past changes that
  // needed no work. Called and returns with `lock` held.
  void save_idle_checkpoint(std::unique_lock<std::mutex>& lock);

 private:
  void save_state(const std::string& site, SiteQueue& q,
                  std::unique_lock<std::mutex>& lock);

  WorkerBoard& board_;
  SiteCommitter& committer_;
};

}  // namespace arscout::engine::service
