// EngineWorker: the feed subscription places captures in sites (on the
// subscription's thread); a small pool runs the sites' increments, one at a
// time per site, each folding in everything queued for its site meanwhile.
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
#include <condition_variable>
#include <deque>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <thread>

#include "arscout/db/errors.h"
#include "arscout/db/path.h"
#include "arscout/db/store.h"
#include "arscout/documents/capture.h"
#include "arscout/engine/service.h"
#include "arscout/util/time.h"
#include "capture_document.h"
#include "capture_preparer.h"
#include "fair_turns.h"
#include "scout_trails.h"
#include "site_directory.h"
#include "site_job.h"
#include "site_leases.h"
#include "thread_priority.h"
#include "worker_metrics.h"

namespace arscout::engine {

using service::PhaseClocks;
using service::Work;

// Times one capture's increment may fail in the engine before the capture
// is rejected (after_engine_fault).
constexpr int kEngineFailures = 2;
// A photo without a fix or hint goes where its scout's photos taken within
// this many seconds of it went (scout_trails.h): a few minutes' walk.
constexpr std::int64_t kScoutTrailWindowS = 600;

struct EngineWorker::Impl {
  Impl(db::Store& s, WorkerOptions o)
      : store(s),
        options(std::move(o)),
        directory(options.site_radius_m),
        leases(store, options.name, options.lease_ttl) {}

  struct SiteQueue {
    // Shared by the lanes: a lane keeps it alive while it runs.
    std::shared_ptr<service::SiteJob> job;
    std::deque<Work> pending;
    std::deque<Work> deferred;  // while another worker holds the site
    // Committed in a model version, but the engine state that holds them
    // is not saved yet (SiteJob::run's save_state): still in flight.
    std::vector<Work> unsaved;
    bool dense_retry = false;    // a dense phase failed: run one again
    bool refine_wanted = false;  // a refinement waits for the dense lane
    // A refinement waits for WorkerOptions::refinement_interval since the
    // last one published (wake_deferred_refinements).
    bool refine_deferred = false;
    std::chrono::steady_clock::time_point last_refinement{};
    // After an increment failed in the engine: captures one at a time, and
    // how often each failed alone (after_engine_fault).
    bool one_at_a_time = false;
    std::map<std::string, int> engine_failures;
    bool running = false;  // its sparse lane
    bool ready = false;
    bool dense_running = false;  // its dense lane
    bool dense_queued = false;
    bool dense_turn = false;  // the dense lane waits for publication()
    // The lane's last phase swept no view and left none waiting: it only
    // re-fuses maps whose cameras moved until an increment comes.
    bool dense_refusing_only = false;
    // Sites that grew into this one, to take in once their lanes are idle
    // (Work::kMerge), and the site this one is to be taken into: it starts
    // no new phase meanwhile.
    std::deque<Work> merges;
    std::string merging_into;
  };

  db::Store& store;
  const WorkerOptions options;
  service::SiteDirectory directory;
  // Where each scout's photos went lately: photos without a fix follow
  // them (scout_trails.h). The placing thread's own.
  service::ScoutTrails trails{kScoutTrailWindowS};
  // Used by the heartbeat thread, but for settled_through (a plain read).
  service::SiteLeases leases;

  mutable std::mutex mutex;
  std::condition_variable changed;
  std::map<std::string, SiteQueue> sites;
  std::deque<std::string> ready;
  std::deque<std::string> dense_ready;
  std::multiset<std::int64_t> in_flight;
  std::int64_t last_placed = 0;  // every change <= it is done or in flight
  std::int64_t saved_checkpoint = 0;
  bool stopping = false;
  std::set<std::string> held;  // sites whose lease this worker holds
  bool claim_wanted = false;   // work was deferred since the last beat
  std::condition_variable beat_cv;
  WorkerStats stats;
  PhaseClocks phases;  // thread-safe on its own
  std::unique_ptr<db::Subscription> subscription;
  std::vector<std::thread> threads;
  // Photos prepared ahead of their increments (capture_preparer.h); null
  // when none are.
  std::unique_ptr<service::CapturePreparer> preparer = make_preparer();

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

  void log(const std::string& line) const {
    if (options.progress) options.progress(line);
  }

  // --- placing (subscription thread) -----------------------------------
  void on_change(const db::Change& change) {
    {
      std::lock_guard lock(mutex);
      ++stats.changes_seen;
    }
    std::vector<std::pair<std::string, Work>> queued;
    // Placing reads the store; while it fails (a restarting database) the
    // feed waits here, in order, rather than skipping the change.
    for (int attempt = 1;; ++attempt) {
      try {
        queued = place(change);
        break;
      } catch (const std::exception& e) {
        log("placing seq " + std::to_string(change.seq) + " failed (attempt " +
            std::to_string(attempt) + "), retrying: " + e.what());
        std::unique_lock lock(mutex);
        if (changed.wait_for(lock, std::chrono::seconds(1),
                             [&] { return stopping; }))
          return;
      }
    }
    std::lock_guard lock(mutex);
    for (const auto& [site, work] : queued) {
      SiteQueue& q = sites[site];
      if (work.kind == Work::Kind::kMerge) {
        request_merge(site, q, work);
        continue;
      }
      in_flight.insert(change.seq);
      if (held.count(site)) {
        q.pending.push_back(work);
        if (preparer && work.kind == Work::Kind::kAdd)
          preparer->want(work.capture);
        make_ready(site, q);
      } else {
        q.deferred.push_back(work);
        claim_wanted = true;
        beat_cv.notify_all();
      }
    }
    last_placed = std::max(last_placed, change.seq);
    changed.notify_all();
  }

  // The work a capture change asks for, and its site: none for changes
  // that need none (the engine's own status updates among them); with a
  // new capture, the merges of the sites its fix meets as well.
  std::vector<std::pair<std::string, Work>> place(const db::Change& change) {
    // Its own status updates need no work.
    if (change.op == db::OpType::kDelete || change.author == options.name)
      return {};
    auto doc = store.get(change.path);
    if (!doc || doc->kind != "capture") return {};
    const std::string id(db::leaf_name(change.path));
    const documents::Capture capture = documents::capture_from_json(doc->attrs);
    if (capture.status == documents::CaptureStatus::kWithdrawn) {
      auto site = directory.site_of(id);
      if (!site) return {};
      return {
          {*site, Work{Work::Kind::kWithdraw, id, change.seq, capture.scout}}};
    }
    if (capture.status != documents::CaptureStatus::kStored &&
        capture.status != documents::CaptureStatus::kNeedsGps)
      return unsaved_work(change, id, capture);
    // The engine patches `site` in the batch that commits the capture into
    // its site's state: a capture carrying it (a photo still waiting for
    // neighbours, as another worker published it) needs nothing more.
    if (!capture.site.empty() && directory.site_of(id) == capture.site)
      return {};
    // A capture placed before (the change seen again after a restart) goes
    // to its site again: the site's state says whether it was processed.
    const auto fix = service::geo_fix(capture.gps);
    const std::int64_t taken = taken_s(capture);
    std::optional<std::string> site;
    if (fix || !capture.site_hint.empty())
      site = directory.place(id, fix, capture.site_hint,
                             default_site_name(capture, taken));
    else if (auto near = trails.site_near(capture.scout, taken))
      site = directory.place_in(id, *near);
    if (!site) return wait_for_position(change, id, capture, taken);
    trails.placed(capture.scout, taken, *site);
    {
      std::lock_guard lock(mutex);
      ++stats.captures_placed;
    }
    log("capture " + id + " -> site " + *site);
    std::vector<std::pair<std::string, Work>> work{
        {*site, Work{Work::Kind::kAdd, id, change.seq, capture.scout}}};
    // Its scout's photos that waited for a position follow it.
    for (const std::string& waited : trails.release(capture.scout, taken))
      if (auto to = directory.place_in(waited, *site)) {
        log("capture " + waited + " -> site " + *to + " (by " + capture.scout +
            "'s photos)");
        work.push_back(
            {*to, Work{Work::Kind::kAdd, waited, change.seq, capture.scout}});
      }
    // Sites whose footprints this fix reaches too grow into this one.
    if (fix) {
      for (const std::string& other : directory.meeting(*site, *fix))
        work.push_back(
            {*site, Work{Work::Kind::kMerge, other, change.seq, ""}});
    }
    return work;
  }

  // A capture with no fix, no hint and no photo of its scout's placed
  // within the trails' window: kept (not rejected) until one is.
  std::vector<std::pair<std::string, Work>> wait_for_position(
      const db::Change& change, const std::string& id,
      const documents::Capture& capture, std::int64_t taken) {
    trails.wait(capture.scout, taken, id);
    store.batch({db::WriteOp::patch(
        change.path,
        documents::status_patch(
            documents::CaptureStatus::kNeedsGps,
            "waiting for a position: no GPS fix, no site hint, and no photo "
            "of " +
                capture.scout + "'s placed within " +
                std::to_string(trails.window_s() / 60) +
                " minutes of it yet"))});
    log("capture " + id + ": waiting for a position");
    return {};
  }

  // A new site's name until someone renames it: its founding scout and
  // when the photo was taken, "alice 2026-12-06 14:05" (UTC).
  static std::string default_site_name(const documents::Capture& capture,
                                       std::int64_t taken) {
    std::string when = util::format_time_utc(taken);  // 2026-12-06T14:05:09Z
    when = when.substr(0, 16);
    if (when.size() > 10) when[10] = ' ';
    return (capture.scout.empty() ? std::string("site") : capture.scout) + " " +
           when;
  }

  // A photo's own time: when it was taken, else when it was received.
  static std::int64_t taken_s(const documents::Capture& capture) {
    if (auto t = util::parse_time_utc(capture.taken)) return *t;
    return util::parse_time_utc(capture.received).value_or(0);
  }

  // A capture an earlier run committed into a model (its status says
  // where it went) while the site's engine state was left unsaved
  // (WorkerOptions::state_interval): the saved state has not folded this
  // change in, so it is added again; else nothing. A capture the state
  // holds after all is skipped by the increment.
  std::vector<std::pair<std::string, Work>> unsaved_work(
      const db::Change& change, const std::string& id,
      const documents::Capture& capture) {
    if (capture.status == documents::CaptureStatus::kRejected) return {};
    const auto site = directory.site_of(id);
    if (!site || change.seq <= leases.settled_through(*site)) return {};
    return {{*site, Work{Work::Kind::kAdd, id, change.seq, capture.scout}}};
  }

  // Site `work.capture` grew into `site`: both held here and neither
  // promised to a third, it is taken in once its lanes are idle. Else
  // nothing: the next capture where they meet asks again.
  void request_merge(const std::string& site, SiteQueue& q, const Work& work) {
    const std::string& other = work.capture;
    SiteQueue& qb = sites[other];
    if (!held.count(site) || !held.count(other) || !q.merging_into.empty() ||
        !qb.merging_into.empty())
      return;
    qb.merging_into = site;
    in_flight.insert(work.seq);
    q.merges.push_back(work);
    log("site " + other + " meets site " + site + ": merging once idle");
    make_ready(site, q);
  }

  static bool lanes_idle(const SiteQueue& q) {
    return !q.running && !q.dense_running && !q.dense_queued && !q.dense_turn;
  }

  // A merge whose other site's lanes are idle.
  bool merge_ready(const SiteQueue& q) {
    return std::any_of(q.merges.begin(), q.merges.end(), [&](const Work& w) {
      return lanes_idle(sites[w.capture]);
    });
  }

  void make_ready(const std::string& site, SiteQueue& q) {
    // A site promised to another waits for it, its work kept for it.
    if (q.running || q.ready || !q.merging_into.empty() ||
        (q.pending.empty() && !q.dense_retry && !q.refine_wanted &&
         !merge_ready(q)))
      return;
    q.ready = true;
    ready.push_back(site);
  }

  // --- increments (pool threads) -----------------------------------------
  void run_sites() {
    std::unique_lock lock(mutex);
    while (true) {
      changed.wait_for(lock, std::chrono::seconds(1),
                       [&] { return stopping || !ready.empty(); });
      if (stopping) return;
      wake_deferred_refinements();
      if (ready.empty()) {
        save_idle_states(lock);
        save_idle_checkpoint(lock);
        continue;
      }
      const std::string site = ready.front();
      ready.pop_front();
      SiteQueue& q = sites[site];
      q.ready = false;
      if (!held.count(site)) {
        defer(q);
        continue;
      }
      if (!q.merging_into.empty()) continue;          // waits to be taken in
      if (directory.current(site) != site) continue;  // taken in already
      q.running = true;
      const bool retry_dense = q.dense_retry;
      q.dense_retry = q.refine_wanted = false;
      // Deterministic runs take one capture per increment: folding
      // whatever arrived meanwhile depends on timing, and so would the
      // dense phase's choice of views.
      const std::vector<Work> work = service::take_in_turns(
          q.pending, options.reconstruction.deterministic || q.one_at_a_time
                         ? 1
                         : static_cast<std::size_t>(
                               std::max(1, options.increment_captures)));
      const std::int64_t through =
          work.empty() ? 0 : service::settled_through(work, q.pending);
      if (!q.job)
        q.job = std::make_shared<service::SiteJob>(site, store, options,
                                                   preparer.get());
      const std::shared_ptr<service::SiteJob> held_job = q.job;
      service::SiteJob& job = *held_job;
      // A dense phase waiting to publish goes first: the lanes take turns.
      changed.wait(lock, [&] { return stopping || !q.dense_turn; });
      run_merges(site, job, q, lock);
      bool ok = true;  // nothing to add: a refinement that gave way resumes
      std::string engine_fault;
      if (!work.empty() || retry_dense) {
        lock.unlock();
        ok = run_increment(site, job, q, work, through, lock,
                           &engine_fault);  // returns locked
      }
      if (ok && !work.empty()) q.one_at_a_time = false;
      if (ok && held.count(site) &&
          (q.pending.empty() || options.reconstruction.deterministic))
        run_refinement(site, job, q, lock);
      q.running = false;
      if (!ok) {
        q.pending.insert(q.pending.begin(), work.begin(), work.end());
        std::sort(q.pending.begin(), q.pending.end(),
                  [](const Work& a, const Work& b) { return a.seq < b.seq; });
        if (!engine_fault.empty()) after_engine_fault(q, work, engine_fault);
      }
      if (!ok || q.dense_retry) {
        // After a pause: the store may be briefly unavailable (a
        // restarting server).
        lock.unlock();
        std::this_thread::sleep_for(std::chrono::seconds(1));
        lock.lock();
      }
      if (held.count(site)) {
        make_ready(site, q);
      } else {
        defer(q);
        q.job.reset();
      }
      wake_merge(q);
      changed.notify_all();
    }
  }

  // A site promised to another: that one may take it in now.
  void wake_merge(const SiteQueue& q) {
    if (q.merging_into.empty()) return;
    make_ready(q.merging_into, sites[q.merging_into]);
  }

  // --- leases (heartbeat thread) ------------------------------------------
  // Moves a site's queued work aside: another worker holds the site.
  static void defer(SiteQueue& q) {
    q.deferred.insert(q.deferred.end(), q.pending.begin(), q.pending.end());
    q.deferred.insert(q.deferred.end(), q.unsaved.begin(), q.unsaved.end());
    q.pending.clear();
    q.unsaved.clear();
    std::sort(q.deferred.begin(), q.deferred.end(),
              [](const Work& a, const Work& b) { return a.seq < b.seq; });
  }

  // The site became this worker's: its deferred work runs here.
  void gain(const std::string& site) {
    SiteQueue& q = sites[site];
    q.pending.insert(q.pending.end(), q.deferred.begin(), q.deferred.end());
    q.deferred.clear();
    std::sort(q.pending.begin(), q.pending.end(),
              [](const Work& a, const Work& b) { return a.seq < b.seq; });
    make_ready(site, q);
    changed.notify_all();
  }

  void lose(const std::string& site) {
    log("site " + site + ": lease lost to another worker");
    SiteQueue& q = sites[site];
    for (const Work& w : q.merges) drop_merge(w);
    q.merges.clear();
    defer(q);
    // A running one is dropped when done.
    if (!q.running && !q.dense_running) q.job.reset();
  }

  // Work another worker has committed needs nothing more from this one.
  void settle(const std::string& site, std::int64_t through_seq) {
    SiteQueue& q = sites[site];
    while (!q.deferred.empty() && q.deferred.front().seq <= through_seq) {
      in_flight.erase(in_flight.find(q.deferred.front().seq));
      q.deferred.pop_front();
    }
    changed.notify_all();
  }

  void renew_leases() {
    const std::set<std::string> now_held = leases.renew();
    std::lock_guard lock(mutex);
    for (const std::string& site : held)
      if (!now_held.count(site)) lose(site);
    // Held before this process started (a restart under the same name).
    for (const std::string& site : now_held)
      if (!held.count(site)) gain(site);
    held = now_held;
    stats.sites_held = static_cast<std::int64_t>(held.size());
  }

  // Claims the sites with deferred work, within this worker's share; for
  // the others, settles what their holders have committed.
  void claim_sites() {
    std::vector<std::string> wanted;
    std::size_t held_count = 0;
    {
      std::lock_guard lock(mutex);
      claim_wanted = false;
      for (const auto& [id, q] : sites)
        if (!q.deferred.empty() && !held.count(id)) wanted.push_back(id);
      held_count = held.size();
    }
    if (wanted.empty()) return;
    const std::set<std::string> taken =
        leases.claim(wanted, directory.sites().size(), held_count);
    std::map<std::string, std::int64_t> settled;
    for (const std::string& site : wanted)
      if (!taken.count(site)) settled[site] = leases.settled_through(site);
    std::lock_guard lock(mutex);
    for (const std::string& site : taken) {
      log("site " + site + ": lease taken");
      held.insert(site);
      gain(site);
    }
    for (const auto& [site, through] : settled) settle(site, through);
    stats.sites_held = static_cast<std::int64_t>(held.size());
    stats.sites_taken += static_cast<std::int64_t>(taken.size());
  }

  void heartbeat() {
    const auto period =
        std::max(options.lease_ttl / 3, std::chrono::milliseconds(10));
    auto next_renewal = std::chrono::steady_clock::now() + period;
    std::unique_lock lock(mutex);
    while (!stopping) {
      beat_cv.wait_until(lock, next_renewal,
                         [&] { return stopping || claim_wanted; });
      if (stopping) return;
      const bool renew = std::chrono::steady_clock::now() >= next_renewal;
      lock.unlock();
      try {
        if (renew) renew_leases();
        claim_sites();
      } catch (const std::exception& e) {
        log(std::string("lease heartbeat failed, retrying: ") + e.what());
      }
      if (renew) next_renewal = std::chrono::steady_clock::now() + period;
      lock.lock();
    }
  }

  // Runs one increment of a site: the sparse phase, committed with the
  // checkpoint, then starts the dense phase (a further model version).
  // Returns false, with the lock held, when the sparse phase failed.
  // `engine_fault` gets the error when the engine (not the store) failed.
  bool run_increment(const std::string& site, service::SiteJob& job,
                     SiteQueue& q, const std::vector<Work>& work,
                     std::int64_t through, std::unique_lock<std::mutex>& lock,
                     std::string* engine_fault) {
    bool dense_due = false;
    try {
      std::unique_lock publication(job.publication());
      const bool save_state = state_save_due(job);
      service::Increment increment =
          timed([&] { return job.run(work, through, save_state); });
      phases.sparse.observe(increment.seconds);
      lock.lock();
      std::multiset<std::int64_t> others = in_flight;
      if (increment.state_written) {
        for (const Work& w : work) others.erase(others.find(w.seq));
        for (const Work& w : q.unsaved) others.erase(others.find(w.seq));
      }
      const std::int64_t checkpoint =
          others.empty() ? last_placed : *others.begin() - 1;
      lock.unlock();
      commit(site, job, increment, checkpoint);
      dense_due = job.dense_due();
      publication.unlock();
      lock.lock();
      q.unsaved.insert(q.unsaved.end(), work.begin(), work.end());
      if (increment.state_written) release_unsaved(q);
      saved_checkpoint = std::max(saved_checkpoint, checkpoint);
      stats.checkpoint = saved_checkpoint;
      stats.increments += increment.model_written ? 1 : 0;
      sites[site].dense_refusing_only = false;  // its views are to sweep
    } catch (const std::exception& e) {
      // The store's failures pass; the engine's would repeat on these photos.
      const bool in_store = dynamic_cast<const db::StoreError*>(&e) != nullptr;
      if (lock.owns_lock()) lock.unlock();
      reset(job);
      log("site " + site + ": increment failed" +
          (in_store ? ", will retry: " : " in the engine: ") + e.what());
      lock.lock();
      requeue_unsaved(q);
      ++stats.failures;
      if (!in_store) *engine_fault = e.what();
      return false;
    }
    if (dense_due) start_dense(site, job, lock);
    return true;
  }

  // An increment failed in the engine (not the store), which would fail
  // the same way again: its captures are retried one at a time, and one
  // that fails alone kEngineFailures times is rejected with the error, so
  // that one photo never holds its site for good. Called with the lock.
  void after_engine_fault(SiteQueue& q, const std::vector<Work>& work,
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
      op.author = options.name;
      store.batch({op});
    } catch (const std::exception& e) {
      log("capture " + w.capture + ": rejecting it failed: " + e.what());
      return;  // retried: the next failure tries again
    }
    log("capture " + w.capture + ": rejected, the engine failed on it");
    q.engine_failures.erase(w.capture);
    std::erase_if(q.pending, [&](const Work& p) { return p.seq == w.seq; });
    in_flight.erase(in_flight.find(w.seq));
  }

  // Takes in the sites waiting to merge into `site` whose lanes are idle.
  // Called and returns with the lock held; `site`'s sparse lane is this one.
  void run_merges(const std::string& site, service::SiteJob& job, SiteQueue& q,
                  std::unique_lock<std::mutex>& lock) {
    for (auto it = q.merges.begin(); it != q.merges.end();) {
      if (!held.count(it->capture)) {  // lost meanwhile
        drop_merge(*it);
        it = q.merges.erase(it);
        continue;
      }
      if (!lanes_idle(sites[it->capture])) {
        ++it;
        continue;
      }
      const Work w = *it;
      it = q.merges.erase(it);
      run_merge(site, job, w, lock);
      it = q.merges.begin();  // the lock was let go: look again
    }
  }

  // Gives up a merge: the other site goes on on its own.
  void drop_merge(const Work& w) {
    in_flight.erase(in_flight.find(w.seq));
    SiteQueue& qb = sites[w.capture];
    qb.merging_into.clear();
    make_ready(w.capture, qb);
  }

  // Merges the site `w` names into `site`. Called and returns with the
  // lock held, the other site's lanes idle.
  void run_merge(const std::string& site, service::SiteJob& job, const Work& w,
                 std::unique_lock<std::mutex>& lock) {
    const std::string other = w.capture;
    in_flight.erase(in_flight.find(w.seq));
    SiteQueue& qb = sites[other];
    qb.running = true;  // keeps its lanes out
    if (!qb.job)
      qb.job = std::make_shared<service::SiteJob>(other, store, options,
                                                  preparer.get());
    const std::shared_ptr<service::SiteJob> other_job = qb.job;
    lock.unlock();
    bool merged = false, jobs_reset = false;
    try {
      std::scoped_lock both(job.publication(), other_job->publication());
      service::Increment increment =
          timed([&] { return job.absorb(*other_job); });
      directory.merge(other, site);
      documents::Site gone = service::SiteDirectory::to_document(
          *directory.site(other), directory.radius_m());
      gone.state = "merged";
      gone.engine = options.name;
      db::WriteOp gone_op = site_put(other, gone);
      gone_op.expected_version.reset();  // gone: its name matters no more
      increment.ops.push_back(std::move(gone_op));
      commit(site, job, increment, std::nullopt);
      merged = true;
    } catch (const std::invalid_argument& e) {
      log("site " + other + " meets site " + site +
          ", not merged: " + e.what());
    } catch (const std::exception& e) {
      reset(job);
      reset(*other_job);
      jobs_reset = true;
      reload_sites({site, other});
      log("site " + other + " into " + site + ": merge failed: " + e.what());
    }
    lock.lock();
    qb.running = false;
    qb.merging_into.clear();
    SiteQueue& q = sites[site];
    if (jobs_reset) {
      requeue_unsaved(q);
      requeue_unsaved(qb);
    }
    if (merged) {
      // Both states are saved as one now.
      release_unsaved(q);
      release_unsaved(qb);
      // Its queued captures are this site's now.
      q.pending.insert(q.pending.end(), qb.pending.begin(), qb.pending.end());
      q.pending.insert(q.pending.end(), qb.deferred.begin(), qb.deferred.end());
      std::sort(q.pending.begin(), q.pending.end(),
                [](const Work& a, const Work& b) { return a.seq < b.seq; });
      qb.pending.clear();
      qb.deferred.clear();
      // So are the sites that were to grow into it.
      for (const Work& taken : qb.merges) {
        sites[taken.capture].merging_into = site;
        q.merges.push_back(taken);
      }
      qb.merges.clear();
      qb.job.reset();
      ++stats.sites_merged;
      q.dense_refusing_only = false;
      if (job.dense_due()) start_dense(site, job, lock);
    } else {
      make_ready(other, qb);
    }
    changed.notify_all();
  }

  // The directory's view of sites as the store has them (after a failed
  // merge, whose batch did not commit).
  void reload_sites(const std::vector<std::string>& ids) {
    std::map<std::string, db::Json> stored;
    for (const std::string& id : ids)
      if (auto doc = store.get("/sites/" + id)) stored[id] = doc->attrs;
    directory.load(stored);
  }

  // Forgets a job's state after a failure (its next phase restores it).
  static void reset(service::SiteJob& job) {
    std::lock_guard publication(job.publication());
    job.reset();
  }

  bool dense_lanes() const {
    return options.dense && !options.reconstruction.deterministic;
  }

  // A due dense phase: queued for the site's dense lane, or (deterministic
  // runs) run here. Called and returns with the lock held.
  void start_dense(const std::string& site, service::SiteJob& job,
                   std::unique_lock<std::mutex>& lock) {
    if (!dense_lanes()) {
      run_dense_inline(site, job, lock);
      return;
    }
    SiteQueue& q = sites[site];
    if (q.dense_running || q.dense_queued) return;
    q.dense_queued = true;
    dense_ready.push_back(site);
    changed.notify_all();
  }

  // The dense phase in the sparse lane, committed as a further model
  // version. Called and returns with the lock held.
  void run_dense_inline(const std::string& site, service::SiteJob& job,
                        std::unique_lock<std::mutex>& lock) {
    lock.unlock();
    try {
      std::lock_guard publication(job.publication());
      service::Increment dense = timed([&] { return job.run_dense(); });
      phases.dense.observe(dense.seconds);
      if (!dense.ops.empty()) commit(site, job, dense, std::nullopt);
      lock.lock();
      stats.increments += dense.model_written ? 1 : 0;
    } catch (const std::exception& e) {
      dense_failed(site, job, lock, e);
    }
  }

  // The sparse phase stands; the engine state says the dense cloud is
  // behind, so the site's next increment (or a restart) catches up.
  // Returns with the lock held.
  void dense_failed(const std::string& site, service::SiteJob& job,
                    std::unique_lock<std::mutex>& lock,
                    const std::exception& e) {
    if (lock.owns_lock()) lock.unlock();
    reset(job);
    log("site " + site + ": dense phase failed, will catch up: " + e.what());
    lock.lock();
    requeue_unsaved(sites[site]);
    sites[site].dense_retry = true;
    ++stats.failures;
  }

  // --- dense lanes (their own threads) -------------------------------------
  void run_dense_lanes() {
    std::unique_lock lock(mutex);
    while (true) {
      changed.wait(lock, [&] { return stopping || !dense_ready.empty(); });
      if (stopping) return;
      const std::string site = dense_ready.front();
      dense_ready.pop_front();
      SiteQueue& q = sites[site];
      q.dense_queued = false;
      if (!held.count(site) || !q.job) continue;
      if (!q.merging_into.empty()) {  // its views are swept again there
        wake_merge(q);
        continue;
      }
      const std::shared_ptr<service::SiteJob> job = q.job;
      q.dense_running = true;
      lock.unlock();
      DenseLaneEnd end;
      try {
        end = run_dense_lane(site, q, *job);
        lock.lock();
      } catch (const std::exception& e) {
        dense_failed(site, *job, lock, e);
      }
      q.dense_running = q.dense_turn = false;
      q.dense_refusing_only = end.refusing_only;
      wake_merge(q);
      if (end.dense_due) start_dense(site, *job, lock);
      // A refinement that gave way to this lane resumes, unless work came.
      q.refine_wanted = end.refinement_due && q.pending.empty();
      if (q.dense_retry || q.refine_wanted) make_ready(site, q);
      changed.notify_all();
    }
  }

  // What is due when a dense lane ends: another dense phase (the model
  // changed meanwhile), the refinement (it gave way to this lane).
  struct DenseLaneEnd {
    bool dense_due = false;
    bool refinement_due = false;
    bool refusing_only = false;  // it swept nothing and nothing waits
  };

  // One dense phase of the site, its sweeping beside the sparse lane.
  DenseLaneEnd run_dense_lane(const std::string& site, SiteQueue& q,
                              service::SiteJob& job) {
    const auto start = std::chrono::steady_clock::now();
    std::optional<service::DenseTask> task;
    {
      set_dense_turn(q, true);
      std::lock_guard publication(job.publication());
      set_dense_turn(q, false);
      task = job.begin_dense();
    }
    if (!task) return {};
    // OpenCV's shared pool runs at full priority, and while a sweep holds
    // it the sparse lane's own parallel calls (SIFT) run serially: the
    // sweep takes the pool only while the sparse lane is idle, asked again
    // every quarter sweep or so (a photo may arrive at any moment).
    task->parallel = [this, &q] {
      std::lock_guard guard(mutex);
      return !q.running && q.pending.empty();
    };
    // The sweep yields the CPU to the sparse lane, whose latency a scout
    // waits on; the publication after it does not, as the sparse lane
    // waits for it.
    service::run_at_lane_priority(service::BackgroundLane::kDense,
                                  [&] { job.compute_dense(*task); });
    set_dense_turn(q, true);  // a refinement gives way too
    std::lock_guard publication(job.publication());
    service::Increment dense = job.finish_dense(*task);
    append_ready_time(dense, start);
    phases.dense.observe(dense.seconds);
    if (!dense.ops.empty()) commit(site, job, dense, std::nullopt);
    std::lock_guard guard(mutex);
    stats.increments += dense.model_written ? 1 : 0;
    const bool refusing_only =
        task->update.new_depth_maps.empty() && task->update.deferred_views == 0;
    return {job.dense_due(), job.refinement_due(), refusing_only};
  }

  // The site's global refinement while it has no work waiting: it gives
  // way (after the solver iteration under way) as soon as work arrives or
  // the dense lane has work (dense_busy), unless a merge or a loop closure
  // made it urgent, and publishes what it reached as a model version.
  // Deterministic runs let it finish, so that a replay gives the same models
  // however fast it arrives. Called and returns with the lock held.
  void run_refinement(const std::string& site, service::SiteJob& job,
                      SiteQueue& q, std::unique_lock<std::mutex>& lock) {
    const bool give_way = !options.reconstruction.deterministic;
    if (refinement_too_soon(job, q)) {
      q.refine_deferred = true;
      return;
    }
    lock.unlock();
    bool dense_due = false;
    try {
      std::lock_guard publication(job.publication());
      const bool urgent = job.refinement_urgent();
      if (!job.refinement_due() || (!urgent && dense_busy(q))) {
        lock.lock();
        return;
      }
      service::Increment refined;
      int written = 0;
      bool state_saved = false;
      // Registered waiting captures make the adjustment due: a
      // deterministic run does it at once (the order must not depend on
      // arrivals), the others after new work and the views' cloud.
      do {
        refined = timed([&] {
          return job.run_refine([&] {
            std::lock_guard guard(mutex);
            return stopping ||
                   (give_way &&
                    (!q.pending.empty() || (!urgent && dense_busy_locked(q))));
          });
        });
        phases.refine.observe(refined.seconds);
        if (!refined.ops.empty()) commit(site, job, refined, std::nullopt);
        written += refined.model_written ? 1 : 0;
        state_saved = state_saved || refined.state_written;
      } while (refined.refine_again && !give_way);
      dense_due = job.dense_due();
      lock.lock();
      if (written > 0) q.last_refinement = std::chrono::steady_clock::now();
      if (state_saved) release_unsaved(q);
      stats.increments += written;
      // A round that used up its iterations goes on in the next call (the
      // core bounds the rounds on one model), as does the adjustment that
      // registered captures or merged components make due; with dense
      // phases the lane's end asks for it, without them nothing else would.
      if ((refined.refine_again || (written > 0 && job.refinement_due())) &&
          !dense_due)
        q.refine_wanted = true;
    } catch (const std::exception& e) {
      if (lock.owns_lock()) lock.unlock();
      reset(job);
      log("site " + site + ": refinement failed, will retry: " + e.what());
      lock.lock();
      requeue_unsaved(q);
      return;
    }
    // The refined poses move the depth maps: the cloud follows them, unless
    // work arrived (its increment's dense phase does it then).
    if (dense_due && (!give_way || q.pending.empty()))
      start_dense(site, job, lock);
  }

  // A refinement round due before the site's interval since its last one
  // has passed (WorkerOptions::refinement_interval), and not urgent.
  bool refinement_too_soon(const service::SiteJob& job, const SiteQueue& q) {
    if (options.refinement_interval.count() <= 0 ||
        options.reconstruction.deterministic || !job.refinement_due() ||
        job.refinement_urgent())
      return false;
    return std::chrono::steady_clock::now() - q.last_refinement <
           options.refinement_interval;
  }

  // Deferred refinements whose interval has passed are made ready.
  // Called with the lock held.
  void wake_deferred_refinements() {
    const auto now = std::chrono::steady_clock::now();
    for (auto& [site, q] : sites) {
      if (!q.refine_deferred ||
          now - q.last_refinement < options.refinement_interval)
        continue;
      q.refine_deferred = false;
      q.refine_wanted = true;
      make_ready(site, q);
    }
  }

  // The dense lane asks for its turn at publication(): the sparse lane
  // lets it go first (it would otherwise take the lock again at once).
  void set_dense_turn(SiteQueue& q, bool waiting) {
    std::lock_guard guard(mutex);
    q.dense_turn = waiting;
    if (!waiting) changed.notify_all();
  }

  // The site's dense lane has work (queued, sweeping, or waiting to
  // publish). The refinement then waits: the new photos' cloud comes before
  // the old photos' last millimetres, and every refined pose would only
  // add maps to re-fuse. It resumes when the lane ends (refine_wanted).
  // Not for a lane that only re-fuses moved maps: after a long walk that
  // is minutes of phases (8 maps each), each moving nothing the refinement
  // would not move again, and the model stayed unrefined meanwhile (two
  // scouts on seed 31's block: one round in 420 s; bench/RESULTS.md,
  // "Issue 35, fourth stop"). That lane waits for the round instead.
  // Nor after a merge or a loop closure (SiteJob::refinement_urgent):
  // the cameras across the seam may be decimetres off, and the lane
  // sweeping new views after four scouts' walk kept the merged model
  // unrefined for ten minutes (seed 53; "Issue 35, nineteenth stop").
  bool dense_busy(const SiteQueue& q) {
    std::lock_guard guard(mutex);
    return dense_busy_locked(q);
  }
  static bool dense_busy_locked(const SiteQueue& q) {
    return (q.dense_turn || q.dense_running || q.dense_queued) &&
           !q.dense_refusing_only;
  }

  // Calls make() and appends its time to the increment's summary.
  template <typename Make>
  static service::Increment timed(Make make) {
    const auto start = std::chrono::steady_clock::now();
    service::Increment increment = make();
    append_ready_time(increment, start);
    return increment;
  }

  static void append_ready_time(service::Increment& increment,
                                std::chrono::steady_clock::time_point start) {
    increment.seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
            .count();
    increment.summary +=
        ", ready in " +
        std::to_string(static_cast<int>(increment.seconds * 1000)) + " ms";
  }

  // Whether the next increment of `job` writes the engine state: always in
  // deterministic runs, else once its unsaved work is options.state_interval
  // old (and when the site goes quiet, save_idle_states).
  bool state_save_due(const service::SiteJob& job) const {
    if (options.reconstruction.deterministic ||
        options.state_interval.count() <= 0)
      return true;
    return job.seconds_state_unsaved() * 1000 >=
           static_cast<double>(options.state_interval.count());
  }

  // A saved state holds q's unsaved work: it is done. Called with the lock.
  void release_unsaved(SiteQueue& q) {
    for (const Work& w : q.unsaved) in_flight.erase(in_flight.find(w.seq));
    q.unsaved.clear();
  }

  // The job lost its in-memory state: its unsaved work runs again (the
  // restored state skips nothing of it). Called with the lock.
  void requeue_unsaved(SiteQueue& q) {
    if (q.unsaved.empty()) return;
    q.pending.insert(q.pending.end(), q.unsaved.begin(), q.unsaved.end());
    q.unsaved.clear();
    std::sort(q.pending.begin(), q.pending.end(),
              [](const Work& a, const Work& b) { return a.seq < b.seq; });
  }

  // Saves the engine state of every quiet site with unsaved work (no
  // phase running or due), so that the checkpoint can pass it. Called and
  // returns with the lock held.
  void save_idle_states(std::unique_lock<std::mutex>& lock) {
    for (auto& [site, q] : sites) {
      if (q.unsaved.empty() || q.running || q.ready || !q.pending.empty() ||
          q.dense_turn || !q.job || !held.count(site))
        continue;
      save_state(site, q, lock);
      return;  // the lock was let go: the next quiet second does the rest
    }
  }

  void save_state(const std::string& site, SiteQueue& q,
                  std::unique_lock<std::mutex>& lock) {
    q.running = true;
    const std::shared_ptr<service::SiteJob> job = q.job;
    lock.unlock();
    bool saved = false;
    try {
      std::lock_guard publication(job->publication());
      service::Increment increment = timed([&] { return job->save_state(); });
      if (!increment.ops.empty()) {
        lock.lock();
        std::multiset<std::int64_t> others = in_flight;
        for (const Work& w : q.unsaved) others.erase(others.find(w.seq));
        const std::int64_t checkpoint =
            others.empty() ? last_placed : *others.begin() - 1;
        lock.unlock();
        commit(site, *job, increment, checkpoint);
        saved = true;
        lock.lock();
        saved_checkpoint = std::max(saved_checkpoint, checkpoint);
        stats.checkpoint = saved_checkpoint;
        lock.unlock();
      }
    } catch (const std::exception& e) {
      if (lock.owns_lock()) lock.unlock();
      log("site " + site + ": engine state not saved, will retry: " + e.what());
    }
    lock.lock();
    if (saved) release_unsaved(q);
    q.running = false;
    make_ready(site, q);
    changed.notify_all();
  }

  // The site document as the engine writes it, with the name a person
  // gave it (PATCH /v1/sites/{id}) kept, expected at the version read.
  db::WriteOp site_put(const std::string& site, documents::Site doc) {
    const auto stored = store.get("/sites/" + site);
    if (stored) doc.name = stored->attrs.value("name", doc.name);
    return db::WriteOp::put("/sites/" + site, "site", documents::to_json(doc),
                            stored ? stored->version : 0);
  }

  // Commits an increment's writes with the site document (and the
  // checkpoint, when given) in one batch, authored by this worker.
  void commit(const std::string& site, service::SiteJob& job,
              service::Increment& increment,
              std::optional<std::int64_t> checkpoint) {
    directory.follow(site, increment.footprint, increment.settled);
    const auto info = directory.site(site);
    documents::Site doc =
        service::SiteDirectory::to_document(*info, directory.radius_m());
    doc.registered = static_cast<int>(job.registered());
    doc.model_version = job.model_version() + (increment.model_written ? 1 : 0);
    doc.state = job.registered() > 0 ? "modelled" : "waiting";
    doc.engine = options.name;
    const std::size_t site_op = increment.ops.size();
    increment.ops.push_back(site_put(site, doc));
    if (checkpoint)
      increment.ops.push_back(db::WriteOp::put("/checkpoints/" + options.name,
                                               "checkpoint",
                                               db::Json{{"seq", *checkpoint}}));
    for (db::WriteOp& op : increment.ops) op.author = options.name;
    const auto start = std::chrono::steady_clock::now();
    for (int attempt = 1;; ++attempt) {
      try {
        store.batch(increment.ops);
        break;
      } catch (const db::ConflictError& e) {
        // Renamed (PATCH /v1/sites/{id}) between the read and the write:
        // the name read again, the rest as it was.
        if (e.path() != "/sites/" + site || attempt == 3) throw;
        increment.ops[site_op] = site_put(site, doc);
        increment.ops[site_op].author = options.name;
      }
    }
    job.committed();
    log(increment.summary + ", committed in " +
        std::to_string(
            static_cast<int>(std::chrono::duration<double, std::milli>(
                                 std::chrono::steady_clock::now() - start)
                                 .count())) +
        " ms");
  }

  // With nothing in flight the feed position can move past changes that
  // needed no work.
  void save_idle_checkpoint(std::unique_lock<std::mutex>& lock) {
    if (!in_flight.empty() || last_placed <= saved_checkpoint) return;
    const std::int64_t seq = last_placed;
    lock.unlock();
    try {
      db::WriteOp op = db::WriteOp::put("/checkpoints/" + options.name,
                                        "checkpoint", db::Json{{"seq", seq}});
      op.author = options.name;
      store.batch({op});
      lock.lock();
      saved_checkpoint = std::max(saved_checkpoint, seq);
      stats.checkpoint = saved_checkpoint;
    } catch (const std::exception& e) {
      log(std::string("checkpoint not saved: ") + e.what());
      lock.lock();
    }
  }

  // The seq of the last capture change committed so far.
  std::int64_t last_capture_change() {
    std::int64_t last = 0;
    {
      std::lock_guard lock(mutex);
      last = last_placed;
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
};

EngineWorker::EngineWorker(db::Store& store, WorkerOptions options)
    : impl_(std::make_unique<Impl>(store, std::move(options))) {}

EngineWorker::~EngineWorker() { stop(); }

void EngineWorker::start() {
  Impl& w = *impl_;
  std::map<std::string, db::Json> stored;
  for (const db::Document& doc : w.store.list_children("/sites"))
    if (doc.kind == "site")
      stored[std::string(db::leaf_name(doc.path))] = doc.attrs;
  w.directory.load(stored);
  const std::int64_t since = w.store.load_checkpoint(w.options.name);
  {
    std::lock_guard lock(w.mutex);
    w.last_placed = w.saved_checkpoint = w.stats.checkpoint = since;
    w.stopping = false;
    // A restarted worker begins afresh from the checkpoint.
    w.sites.clear();
    w.ready.clear();
    w.dense_ready.clear();
    w.in_flight.clear();
    w.held.clear();
  }
  w.log("engine " + w.options.name + ": " + std::to_string(stored.size()) +
        " sites, following /captures/* from seq " + std::to_string(since));
  w.renew_leases();
  w.threads.emplace_back([&w] { w.heartbeat(); });
  for (int i = 0; i < std::max(1, w.options.site_threads); ++i) {
    w.threads.emplace_back([&w] { w.run_sites(); });
    if (w.dense_lanes()) w.threads.emplace_back([&w] { w.run_dense_lanes(); });
  }
  w.subscription = w.store.subscribe(
      "/captures/*", since, [&w](const db::Change& c) { w.on_change(c); });
}

void EngineWorker::stop() {
  Impl& w = *impl_;
  if (w.subscription) {
    w.subscription->stop();
    w.subscription.reset();
  }
  {
    std::lock_guard lock(w.mutex);
    w.stopping = true;
  }
  w.changed.notify_all();
  w.beat_cv.notify_all();
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
    w.log(std::string("leases not released (they will expire): ") + e.what());
  }
  std::lock_guard lock(w.mutex);
  for (auto& [id, q] : w.sites) {
    w.defer(q);
    q.job.reset();
  }
  w.held.clear();
  w.stats.sites_held = 0;
}

bool EngineWorker::wait_idle(std::chrono::milliseconds timeout) {
  Impl& w = *impl_;
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  const std::int64_t target = w.last_capture_change();
  std::unique_lock lock(w.mutex);
  return w.changed.wait_until(lock, deadline, [&] {
    if (w.last_placed < target || !w.in_flight.empty()) return false;
    for (const auto& [id, q] : w.sites)
      if (q.running || !q.pending.empty() || q.dense_retry || q.dense_running ||
          q.dense_queued || q.refine_wanted || q.refine_deferred || q.ready)
        return false;
    return true;
  });
}

WorkerStats EngineWorker::stats() const {
  std::lock_guard lock(impl_->mutex);
  WorkerStats s = impl_->stats;
  s.sites = static_cast<std::int64_t>(impl_->sites.size());
  // Every placed change is in flight until its increment commits (and
  // after, until the engine state that holds it is saved).
  std::int64_t unsaved = 0;
  for (const auto& [id, q] : impl_->sites)
    unsaved += static_cast<std::int64_t>(q.unsaved.size());
  s.captures_waiting =
      static_cast<std::int64_t>(impl_->in_flight.size()) - unsaved;
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
  return service::render_metrics(stats(), impl_->phases, head);
}

}  // namespace arscout::engine
