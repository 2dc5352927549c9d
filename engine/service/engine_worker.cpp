// EngineWorker: the feed subscription places captures in sites (on the
// subscription's thread); a small pool runs the sites' increments, one at a
// time per site, each folding in everything queued for its site meanwhile.
//
// The checkpoint: every change up to the last one placed is either done or
// queued; queued changes are "in flight" until the increment holding them
// commits. A commit saves, in its own batch, the position just below the
// oldest change still in flight, so a crash never skips work (it may redo
// some: delivery is at least once, and the restored state skips what it
// already holds).
#include <algorithm>
#include <condition_variable>
#include <deque>
#include <map>
#include <mutex>
#include <set>
#include <thread>

#include "arscout/db/path.h"
#include "arscout/db/store.h"
#include "arscout/engine/service.h"
#include "capture_document.h"
#include "site_directory.h"
#include "site_job.h"

namespace arscout::engine {

using service::Work;

struct EngineWorker::Impl {
  Impl(db::Store& s, WorkerOptions o)
      : store(s), options(std::move(o)), directory(options.site_radius_m) {}

  struct SiteQueue {
    std::unique_ptr<service::SiteJob> job;
    std::deque<Work> pending;
    bool running = false;
    bool ready = false;
  };

  db::Store& store;
  const WorkerOptions options;
  service::SiteDirectory directory;

  mutable std::mutex mutex;
  std::condition_variable changed;
  std::map<std::string, SiteQueue> sites;
  std::deque<std::string> ready;
  std::multiset<std::int64_t> in_flight;
  std::int64_t last_placed = 0;  // every change <= it is done or in flight
  std::int64_t saved_checkpoint = 0;
  bool stopping = false;
  WorkerStats stats;
  std::unique_ptr<db::Subscription> subscription;
  std::vector<std::thread> threads;

  void log(const std::string& line) const {
    if (options.progress) options.progress(line);
  }

  // --- placing (subscription thread) -----------------------------------
  void on_change(const db::Change& change) {
    {
      std::lock_guard lock(mutex);
      ++stats.changes_seen;
    }
    std::optional<std::pair<std::string, Work>> queued;
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
    if (queued) {
      SiteQueue& q = sites[queued->first];
      q.pending.push_back(queued->second);
      in_flight.insert(change.seq);
      make_ready(queued->first, q);
    }
    last_placed = std::max(last_placed, change.seq);
    changed.notify_all();
  }

  // The work a capture change asks for, and its site; nullopt for changes
  // that need none (the engine's own status updates among them).
  std::optional<std::pair<std::string, Work>> place(const db::Change& change) {
    // Its own status updates need no work.
    if (change.op == db::OpType::kDelete || change.author == options.name)
      return std::nullopt;
    auto doc = store.get(change.path);
    if (!doc || doc->kind != "capture") return std::nullopt;
    const std::string id(db::leaf_name(change.path));
    const std::string status = doc->attrs.value("status", "");
    if (status == "withdrawn") {
      auto site = directory.site_of(id);
      if (!site) return std::nullopt;
      return std::make_pair(*site, Work{Work::Kind::kWithdraw, id, change.seq});
    }
    if (status != "stored" && status != "needs-gps") return std::nullopt;
    // A capture placed before (the change seen again after a restart) goes
    // to its site again: the site's state says whether it was processed.
    const std::optional<GeoFix> fix = service::capture_fix(doc->attrs);
    const std::string hint = doc->attrs.value("site_hint", "");
    auto site = directory.place(id, fix, hint);
    if (!site) {
      store.batch({db::WriteOp::patch(
          change.path, db::Json{{"status", "rejected"},
                                {"status_reason",
                                 "no GPS fix and no site hint: the "
                                 "engine cannot tell which site it shows"}})});
      log("capture " + id + ": rejected (no GPS fix, no site hint)");
      return std::nullopt;
    }
    {
      std::lock_guard lock(mutex);
      ++stats.captures_placed;
    }
    log("capture " + id + " -> site " + *site);
    return std::make_pair(*site, Work{Work::Kind::kAdd, id, change.seq});
  }

  void make_ready(const std::string& site, SiteQueue& q) {
    if (q.running || q.ready || q.pending.empty()) return;
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
      if (ready.empty()) {
        save_idle_checkpoint(lock);
        continue;
      }
      const std::string site = ready.front();
      ready.pop_front();
      SiteQueue& q = sites[site];
      q.ready = false;
      q.running = true;
      std::vector<Work> work(q.pending.begin(), q.pending.end());
      q.pending.clear();
      if (!q.job)
        q.job = std::make_unique<service::SiteJob>(site, store, options);
      service::SiteJob& job = *q.job;
      lock.unlock();
      const bool ok = run_increment(site, job, work, lock);
      // run_increment returns with the lock held.
      q.running = false;
      if (!ok) {
        // Back to the front of the queue, after a pause: the store may be
        // briefly unavailable (a restarting server).
        q.pending.insert(q.pending.begin(), work.begin(), work.end());
        lock.unlock();
        std::this_thread::sleep_for(std::chrono::seconds(1));
        lock.lock();
      }
      make_ready(site, q);
      changed.notify_all();
    }
  }

  bool run_increment(const std::string& site, service::SiteJob& job,
                     const std::vector<Work>& work,
                     std::unique_lock<std::mutex>& lock) {
    try {
      const auto run_start = std::chrono::steady_clock::now();
      service::Increment increment = job.run(work);
      const double run_ms = std::chrono::duration<double, std::milli>(
                                std::chrono::steady_clock::now() - run_start)
                                .count();
      const auto info = directory.site(site);
      lock.lock();
      std::multiset<std::int64_t> others = in_flight;
      for (const Work& w : work) others.erase(others.find(w.seq));
      const std::int64_t checkpoint =
          others.empty() ? last_placed : *others.begin() - 1;
      lock.unlock();
      db::Json attrs =
          service::SiteDirectory::to_attrs(*info, directory.radius_m());
      attrs["registered"] = job.registered();
      attrs["model_version"] =
          job.model_version() + (increment.model_written ? 1 : 0);
      attrs["state"] = job.registered() > 0 ? "modelled" : "waiting";
      increment.ops.push_back(
          db::WriteOp::put("/sites/" + site, "site", attrs));
      increment.ops.push_back(db::WriteOp::put("/checkpoints/" + options.name,
                                               "checkpoint",
                                               db::Json{{"seq", checkpoint}}));
      for (db::WriteOp& op : increment.ops) op.author = options.name;
      const auto commit_start = std::chrono::steady_clock::now();
      store.batch(increment.ops);
      job.committed();
      log(increment.summary + ", ready in " +
          std::to_string(static_cast<int>(run_ms)) + " ms, committed in " +
          std::to_string(static_cast<int>(
              std::chrono::duration<double, std::milli>(
                  std::chrono::steady_clock::now() - commit_start)
                  .count())) +
          " ms");
      lock.lock();
      for (const Work& w : work) in_flight.erase(in_flight.find(w.seq));
      saved_checkpoint = std::max(saved_checkpoint, checkpoint);
      stats.checkpoint = saved_checkpoint;
      stats.increments += increment.model_written ? 1 : 0;
      return true;
    } catch (const std::exception& e) {
      job.reset();
      log("site " + site + ": increment failed, will retry: " + e.what());
      if (!lock.owns_lock()) lock.lock();
      ++stats.failures;
      return false;
    }
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
  }
  w.log("engine " + w.options.name + ": " + std::to_string(stored.size()) +
        " sites, following /captures/* from seq " + std::to_string(since));
  for (int i = 0; i < std::max(1, w.options.site_threads); ++i)
    w.threads.emplace_back([&w] { w.run_sites(); });
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
  for (std::thread& t : w.threads) t.join();
  w.threads.clear();
}

bool EngineWorker::wait_idle(std::chrono::milliseconds timeout) {
  Impl& w = *impl_;
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  const std::int64_t target = w.last_capture_change();
  std::unique_lock lock(w.mutex);
  return w.changed.wait_until(lock, deadline, [&] {
    if (w.last_placed < target || !w.in_flight.empty()) return false;
    for (const auto& [id, q] : w.sites)
      if (q.running || !q.pending.empty()) return false;
    return true;
  });
}

WorkerStats EngineWorker::stats() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->stats;
}

}  // namespace arscout::engine
