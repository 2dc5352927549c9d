// A site's dense phases: queued for the dense lanes (threads of their own,
// sweeping at a lower CPU priority beside the site's sparse lane), or, in
// deterministic runs, run inline in the sparse lane after its increment so
// that what they sweep never depends on timing. Each phase is committed as
// a further model version. The dense lane's states are SiteSchedule's
// DenseState.
#pragma once

#include <exception>
#include <mutex>
#include <string>

#include "site_commit.h"
#include "worker_board.h"

namespace arscout::engine::service {

class DenseLane {
 public:
  DenseLane(WorkerBoard& board, SiteCommitter& committer)
      : board_(board), committer_(committer) {}

  // A due dense phase: queued for the site's dense lane, or (no lanes) run
  // here. Called and returns with `lock` (the board's) held.
  void start(const std::string& site, SiteJob& job,
             std::unique_lock<std::mutex>& lock);
  // The sparse phase stands; the engine state says the dense cloud is
  // behind, so the site's next pick-up (or a restart) catches up. Called
  // with or without `lock`; returns with it held.
  void failed(const std::string& site, SiteJob& job,
              std::unique_lock<std::mutex>& lock, const std::exception& e);
  // A dense lane's thread: takes queued sites until the board stops.
  void run();

 private:
  // What is due when a phase ends.
  struct End {
    bool dense_due = false;       // the model changed meanwhile
    bool refinement_due = false;  // it gave way to this lane
    bool refusing_only = false;   // it swept nothing and nothing waits
  };

  void run_inline(const std::string& site, SiteJob& job,
                  std::unique_lock<std::mutex>& lock);
  // One phase of the site, its sweeping beside the sparse lane. Called
  // without the lock.
  End sweep_and_publish(const std::string& site, SiteQueue& q, SiteJob& job);
  void finish(const std::string& site, SiteQueue& q, SiteJob& job,
              const End& end, std::unique_lock<std::mutex>& lock);
  void on(SiteQueue& q, SiteEvent event);  // takes the lock

  WorkerBoard& board_;
  SiteCommitter& committer_;
};

}  // namespace arscout::engine::service
