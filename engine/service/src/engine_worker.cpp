// EngineWorker: the feed follower places captures in sites (on the
// subscription's thread, capture_placer.h); a small pool runs the sites'
// increments, one at a time per site, each folding in everything queued for
// its site meanwhile (sparse_lane.h). What each site's lanes are doing is
// its SiteSchedule (site_schedule.h), on the board the threads share
// (worker_board.h).
//
// A site's dense phase runs in a lane of its own (its own threads, its
// sweeps at a lower CPU priority), beside the site's next sparse phases: a
// photo's registration never waits for a depth map. The lanes take turns
// only to publish (SiteJob::publication), and the dense lane publishes at
// full priority, since the sparse lane waits for it then. Deterministic runs
// keep the dense phase inline, after the sparse phase, so that what it sweeps
// never depends on timing.
//
// The checkpoint: every change up to the last one placed is either done or
// queued; queued changes are "in flight" until the increment holding them
// commits. A commit saves, in its own batch, the position just below the
// oldest change still in flight, so a crash never skips work (it may redo
// some: delivery is at least once, and the restored state skips what it
// already holds).
//
// Sites are reconstructed only while this worker holds their lease (see
// site_leases.h). Work for a site it does not hold is "deferred": it stays
// in flight, holding the checkpoint back, until the heartbeat either claims
// the site (the work then runs here) or sees the holder's committed state
// pass it (attrs.through_seq of the site's engine document).
#include <algorithm>
#include <chrono>
#include <map>
#include <mutex>
#include <thread>

#include "arscout/db/path.h"
#include "arscout/db/store.h"
#include "arscout/engine/service.h"
#include "capture_document.h"
#include "capture_placer.h"
#include "capture_preparer.h"
#include "dense_lane.h"
#include "lease_heartbeat.h"
#include "refinement_runner.h"
#include "site_commit.h"
#include "site_directory.h"
#include "site_leases.h"
#include "site_merger.h"
#include "sparse_lane.h"
#include "state_saver.h"
#include "worker_board.h"
#include "worker_metrics.h"

namespace arscout::engine {

using service::Work;

// The worker's parts, wired to one board.
struct EngineWorker::Impl {
  Impl(db::Store& s, WorkerOptions o)
      : store(s),
        options(std::move(o)),
        directory(options.site_radius_m),
        leases(store, options.name, options.lease_ttl) {}

  db::Store& store;
  const WorkerOptions options;
  service::SiteDirectory directory;
  service::SiteLeases leases;
  // Photos prepared ahead of their increments (capture_preparer.h); null
  // when none are.
  std::unique_ptr<service::CapturePreparer> preparer = make_preparer();
  service::WorkerBoard board{store, options, directory, preparer.get()};
  service::SiteCommitter committer{store, options, directory};
  service::DenseLane dense{board, committer};
  service::SiteMerger merger{board, committer, dense};
  service::RefinementRunner refinement{board, committer, dense};
  service::StateSaver saver{board, committer};
  service::SparseLane sparse{board,  committer,  dense,
                             merger, refinement, saver};
  service::LeaseHeartbeat heartbeat{board, leases, merger};
  service::CapturePlacer placer{board, leases};
  std::unique_ptr<db::Subscription> subscription;
  std::vector<std::thread> threads;

  std::unique_ptr<service::CapturePreparer> make_preparer() {
    if (options.prepare_ahead <= 0 || options.reconstruction.deterministic)
      return nullptr;
    return std::make_unique<service::CapturePreparer>(
        [this](const std::string& capture) {
          return service::stored_capture_input(store, capture);
        },
        options.reconstruction,
        static_cast<std::size_t>(options.prepare_ahead));
  }

  // The feed follower: places the change and queues its work.
  void on_change(const db::Change& change) {
    {
      std::lock_guard lock(board.mutex);
      ++board.stats.changes_seen;
    }
    std::vector<std::pair<std::string, Work>> queued;
    if (!place_until_done(change, queued)) return;
    std::lock_guard lock(board.mutex);
    for (const auto& [site, work] : queued) queue(site, work, change.seq);
    board.last_placed = std::max(board.last_placed, change.seq);
    board.changed.notify_all();
  }

  // Placing reads the store; while it fails (a restarting database) the
  // feed waits here, in order, rather than skipping the change. False when
  // the worker stops meanwhile.
  bool place_until_done(const db::Change& change,
                        std::vector<std::pair<std::string, Work>>& queued) {
    for (int attempt = 1;; ++attempt) {
      try {
        queued = placer.place(change);
        return true;
      } catch (const std::exception& e) {
        board.log("placing seq " + std::to_string(change.seq) +
                  " failed (attempt " + std::to_string(attempt) +
                  "), retrying: " + e.what());
        std::unique_lock lock(board.mutex);
        if (board.changed.wait_for(lock, std::chrono::seconds(1),
                                   [&] { return board.stopping; }))
          return false;
      }
    }
  }

  // With the lock held.
  void queue(const std::string& site, const Work& work, std::int64_t seq) {
    service::SiteQueue& q = board.sites[site];
    if (work.kind == Work::Kind::kMerge) {
      merger.request(site, q, work);
      return;
    }
    board.in_flight.insert(seq);
    if (board.holds(site)) {
      q.pending.push_back(work);
      if (preparer && work.kind == Work::Kind::kAdd)
        preparer->want(work.capture);
      board.make_ready(site, q);
    } else {
      q.deferred.push_back(work);
      board.claim_wanted = true;
      board.beat_cv.notify_all();
    }
  }

  // The seq of the last capture change committed so far.
  std::int64_t last_capture_change() {
    std::int64_t last = 0;
    {
      std::lock_guard lock(board.mutex);
      last = board.last_placed;
    }
    const std::int64_t end = store.last_seq();
    while (true) {
      auto page = store.changes(last, "/captures/*", 1000);
      if (page.empty()) break;
      for (const db::Change& c : page)
        if (c.seq <= end) last = c.seq;
      if (page.back().seq >= end || page.size() < 1000) break;
    }
    return last;
  }

  // Every site quiet and every change placed before `target` done.
  bool idle(std::int64_t target) const {
    if (board.last_placed < target || !board.in_flight.empty() ||
        !board.ready.empty())
      return false;
    for (const auto& [id, q] : board.sites)
      if (!q.schedule.quiet() || !q.pending.empty()) return false;
    return true;
  }
};

EngineWorker::EngineWorker(db::Store& store, WorkerOptions options)
    : impl_(std::make_unique<Impl>(store, std::move(options))) {}

EngineWorker::~EngineWorker() { stop(); }

void EngineWorker::start() {
  Impl& w = *impl_;
  service::WorkerBoard& b = w.board;
  std::map<std::string, db::Json> stored;
  for (const db::Document& doc : w.store.list_children("/sites"))
    if (doc.kind == "site")
      stored[std::string(db::leaf_name(doc.path))] = doc.attrs;
  w.directory.load(stored);
  const std::int64_t since = w.store.load_checkpoint(w.options.name);
  {
    std::lock_guard lock(b.mutex);
    b.last_placed = b.saved_checkpoint = b.stats.checkpoint = since;
    b.stopping = false;
    // A restarted worker begins afresh from the checkpoint.
    b.sites.clear();
    b.ready.clear();
    b.dense_ready.clear();
    b.in_flight.clear();
    b.held.clear();
  }
  b.log("engine " + w.options.name + ": " + std::to_string(stored.size()) +
        " sites, following /captures/* from seq " + std::to_string(since));
  w.heartbeat.renew();
  w.threads.emplace_back([&w] { w.heartbeat.run(); });
  for (int i = 0; i < std::max(1, w.options.site_threads); ++i) {
    w.threads.emplace_back([&w] { w.sparse.run(); });
    if (b.dense_lanes()) w.threads.emplace_back([&w] { w.dense.run(); });
  }
  w.subscription = w.store.subscribe(
      "/captures/*", since, [&w](const db::Change& c) { w.on_change(c); });
}

void EngineWorker::stop() {
  Impl& w = *impl_;
  service::WorkerBoard& b = w.board;
  if (w.subscription) {
    w.subscription->stop();
    w.subscription.reset();
  }
  {
    std::lock_guard lock(b.mutex);
    b.stopping = true;
  }
  b.changed.notify_all();
  b.beat_cv.notify_all();
  for (std::thread& t : w.threads) t.join();
  // Queued work is dropped (a restart redoes it), and nothing reads the
  // store after stop() returns.
  if (w.preparer) w.preparer->clear();
  const bool had_threads = !w.threads.empty();
  w.threads.clear();
  if (!had_threads) return;
  // The sites go back at once, rather than when their leases expire.
  try {
    w.leases.release();
  } catch (const std::exception& e) {
    b.log(std::string("leases not released (they will expire): ") + e.what());
  }
  std::lock_guard lock(b.mutex);
  for (auto& [id, q] : b.sites) {
    service::WorkerBoard::defer(q);
    q.job.reset();
  }
  b.held.clear();
  b.stats.sites_held = 0;
}

bool EngineWorker::wait_idle(std::chrono::milliseconds timeout) {
  Impl& w = *impl_;
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  const std::int64_t target = w.last_capture_change();
  std::unique_lock lock(w.board.mutex);
  return w.board.changed.wait_until(lock, deadline,
                                    [&] { return w.idle(target); });
}

WorkerStats EngineWorker::stats() const {
  const service::WorkerBoard& b = impl_->board;
  std::lock_guard lock(b.mutex);
  WorkerStats s = b.stats;
  s.sites = static_cast<std::int64_t>(b.sites.size());
  // Every placed change is in flight until its increment commits (and
  // after, until the engine state that holds it is saved).
  std::int64_t unsaved = 0;
  for (const auto& [id, q] : b.sites)
    unsaved += static_cast<std::int64_t>(q.unsaved.size());
  s.captures_waiting = static_cast<std::int64_t>(b.in_flight.size()) - unsaved;
  if (impl_->preparer) {
    const service::CapturePreparer::Counts c = impl_->preparer->counts();
    s.photos_prepared = c.prepared;
    s.photos_prepared_used = c.taken;
    s.photos_prepared_late = c.missed;
  }
  return s;
}

std::string EngineWorker::metrics() const {
  std::optional<std::int64_t> head;
  try {
    head = impl_->store.last_seq();
  } catch (const std::exception&) {
  }
  return service::render_metrics(stats(), impl_->board.phases, head);
}

}  // namespace arscout::engine
