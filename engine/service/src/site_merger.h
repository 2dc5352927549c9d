// Sites that grow into one another: when a new capture's fix reaches the
// footprints of two sites this worker holds, neither promised to a third,
// the other site is promised to this one (SiteQueue::merging_into, it
// starts no new phase) and taken in by this site's sparse lane once the
// other's lanes are idle (SparseState::kHeldByMerge while it is). The
// merged state and the other site's "merged" document commit in one batch.
#pragma once

#include <mutex>
#include <string>
#include <vector>

#include "dense_lane.h"
#include "site_commit.h"
#include "worker_board.h"

namespace arscout::engine::service {

class SiteMerger {
 public:
  SiteMerger(WorkerBoard& board, SiteCommitter& committer, DenseLane& dense)
      : board_(board), committer_(committer), dense_(dense) {}

  // Site `work.capture` grew into `site`: promised to it when both are
  // held here and neither is promised elsewhere; else nothing (the next
  // capture where they meet asks again). Called with the lock held.
  void request(const std::string& site, SiteQueue& q, const Work& work);
  // Takes in the sites waiting to merge into `site` whose lanes are idle.
  // Called and returns with `lock` held; `site`'s sparse lane is the
  // caller's.
  void run_merges(const std::string& site, SiteJob& job, SiteQueue& q,
                  std::unique_lock<std::mutex>& lock);
  // Gives up a merge: the other site goes on on its own. With the lock.
  void drop(const Work& w);

 private:
  // Merges the site `w` names into `site`, the other site's lanes idle.
  // Called and returns with the lock held.
  void run_merge(const std::string& site, SiteJob& job, const Work& w,
                 std::unique_lock<std::mutex>& lock);
  // Commits the absorbed state; throws what absorb and the store throw.
  void commit_merge(const std::string& site, const std::string& other,
                    SiteJob& job, SiteJob& other_job);
  // After a merge committed: the other site's work, and the sites that
  // were to grow into it, are this site's. With the lock.
  void take_over(const std::string& site, SiteQueue& q, SiteQueue& qb);
  // The directory's view of sites as the store has them (after a failed
  // merge, whose batch did not commit).
  void reload_sites(const std::vector<std::string>& ids);

  WorkerBoard& board_;
  SiteCommitter& committer_;
  DenseLane& dense_;
};

}  // namespace arscout::engine::service
