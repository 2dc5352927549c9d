// What the engine worker's threads share, under one mutex: each site's
// queues and schedule (site_schedule.h), the sites waiting for a lane, the
// feed changes in flight and the checkpoint, the leases held, the counters.
//
// The worker's parts act on it: the feed follower (engine_worker.cpp,
// capture_placer.h) queues work, the sparse and dense lanes
// (sparse_lane.h, dense_lane.h) and the refinement run it, the merger
// (site_merger.h) takes sites into others, the heartbeat (lease_heartbeat.h)
// moves work as leases come and go, the state saver (state_saver.h) saves
// quiet sites. The methods here are those several parts need. Every one is
// called with `mutex` held, but log().
//
// The checkpoint: every change up to last_placed is either done or in
// flight; a change stays in flight until the engine state that holds its
// work is saved, and a commit saves the position just below the oldest
// change still in flight, so a crash never skips work.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include "arscout/engine/service.h"
#include "capture_preparer.h"
#include "site_directory.h"
#include "site_job.h"
#include "site_schedule.h"
#include "worker_metrics.h"

namespace arscout::db {
class Store;
}

namespace arscout::engine::service {

// One site's work and schedule.
struct SiteQueue {
  // Shared by the lanes: a lane keeps it alive while it runs.
  std::shared_ptr<SiteJob> job;
  std::deque<Work> pending;
  std::deque<Work> deferred;  // while another worker holds the site
  // Committed in a model version, but the engine state that holds them is
  // not saved yet (SiteJob::run's save_state): still in flight.
  std::vector<Work> unsaved;
  SiteSchedule schedule;
  std::chrono::steady_clock::time_point last_refinement{};
  // After an increment failed in the engine: captures one at a time, and
  // how often each failed alone (SparseLane's after_engine_fault).
  bool one_at_a_time = false;
  std::map<std::string, int> engine_failures;
  // Sites that grew into this one, to take in once their lanes are idle
  // (Work::kMerge), and the site this one is to be taken into: it starts
  // no new phase meanwhile.
  std::deque<Work> merges;
  std::string merging_into;
};

struct WorkerBoard {
  WorkerBoard(db::Store& store_in, const WorkerOptions& options_in,
              SiteDirectory& directory_in, CapturePreparer* preparer_in)
      : store(store_in),
        options(options_in),
        directory(directory_in),
        preparer(preparer_in) {}

  db::Store& store;
  const WorkerOptions& options;
  SiteDirectory& directory;   // thread-safe on its own
  CapturePreparer* preparer;  // null when photos are not prepared ahead
  PhaseClocks phases;         // thread-safe on its own

  mutable std::mutex mutex;
  std::condition_variable changed;  // any of the below changed
  std::condition_variable beat_cv;  // the heartbeat has sites to claim
  std::map<std::string, SiteQueue> sites;
  ReadyQueue ready;                     // for the sparse lanes
  std::deque<std::string> dense_ready;  // for the dense lanes
  std::multiset<std::int64_t> in_flight;
  std::int64_t last_placed = 0;  // every change <= it is done or in flight
  std::int64_t saved_checkpoint = 0;
  bool stopping = false;
  std::set<std::string> held;  // sites whose lease this worker holds
  bool claim_wanted = false;   // work was deferred since the last beat
  WorkerStats stats;

  // Told to WorkerOptions::progress; needs no lock.
  void log(const std::string& line) const;
  bool holds(const std::string& site) const { return held.count(site) > 0; }
  // Dense phases run in lanes of their own (not in deterministic runs).
  bool dense_lanes() const;

  // Queues `site` for a sparse lane when it has work and is not running,
  // queued, or promised to another site.
  void make_ready(const std::string& site, SiteQueue& q);
  // A site promised to another: that one may take it in now.
  void wake_merge(const SiteQueue& q);
  // The job of `site`, made on first use.
  std::shared_ptr<SiteJob> job_for(const std::string& site, SiteQueue& q);

  // Moves a site's queued work aside: another worker holds the site.
  static void defer(SiteQueue& q);
  // The site became this worker's: its deferred work runs here.
  void gain(const std::string& site);
  // Work another worker has committed needs nothing more from this one.
  void settle(const std::string& site, std::int64_t through_seq);

  // A saved state holds q's unsaved work: it is done.
  void release_unsaved(SiteQueue& q);
  // The job lost its in-memory state: its unsaved work runs again.
  void requeue_unsaved(SiteQueue& q);
  // The feed position a commit may save once `done` is: just below the
  // oldest other change in flight.
  std::int64_t checkpoint_without(const std::vector<Work>& done) const;
  void checkpoint_saved(std::int64_t checkpoint);

 private:
  // A merge into q whose other site's lanes are idle.
  bool merge_ready(const SiteQueue& q);
};

// Forgets a job's state after a failure (its next phase restores it).
// Called without the board's lock.
void reset_job(SiteJob& job);

// Sorts work by the seq of the change that asked for it.
void sort_by_seq(std::deque<Work>& work);

}  // namespace arscout::engine::service
