#include "lease_heartbeat.h"

#include <algorithm>
#include <chrono>
#include <map>
#include <set>
#include <vector>

namespace arscout::engine::service {

void LeaseHeartbeat::renew() {
  const std::set<std::string> now_held = leases_.renew();
  std::lock_guard lock(board_.mutex);
  for (const std::string& site : board_.held)
    if (!now_held.count(site)) lose(site);
  // Held before this process started (a restart under the same name).
  for (const std::string& site : now_held)
    if (!board_.held.count(site)) board_.gain(site);
  board_.held = now_held;
  board_.stats.sites_held = static_cast<std::int64_t>(board_.held.size());
}

void LeaseHeartbeat::lose(const std::string& site) {
  board_.log("site " + site + ": lease lost to another worker");
  SiteQueue& q = board_.sites[site];
  for (const Work& w : q.merges) merger_.drop(w);
  q.merges.clear();
  WorkerBoard::defer(q);
  // A running one is dropped when done.
  if (!q.schedule.sparse_busy() && !q.schedule.dense_running()) q.job.reset();
}

// Claims the sites with deferred work, within this worker's share; for the
// others, settles what their holders have committed.
void LeaseHeartbeat::claim() {
  std::vector<std::string> wanted;
  std::size_t held_count = 0;
  {
    std::lock_guard lock(board_.mutex);
    board_.claim_wanted = false;
    for (const auto& [id, q] : board_.sites)
      if (!q.deferred.empty() && !board_.holds(id)) wanted.push_back(id);
    held_count = board_.held.size();
  }
  if (wanted.empty()) return;
  const std::set<std::string> taken =
      leases_.claim(wanted, board_.directory.sites().size(), held_count);
  std::map<std::string, std::int64_t> settled;
  for (const std::string& site : wanted)
    if (!taken.count(site)) settled[site] = leases_.settled_through(site);
  std::lock_guard lock(board_.mutex);
  for (const std::string& site : taken) {
    board_.log("site " + site + ": lease taken");
    board_.held.insert(site);
    board_.gain(site);
  }
  for (const auto& [site, through] : settled) board_.settle(site, through);
  board_.stats.sites_held = static_cast<std::int64_t>(board_.held.size());
  board_.stats.sites_taken += static_cast<std::int64_t>(taken.size());
}

void LeaseHeartbeat::run() {
  const auto period =
      std::max(board_.options.lease_ttl / 3, std::chrono::milliseconds(10));
  auto next_renewal = std::chrono::steady_clock::now() + period;
  std::unique_lock lock(board_.mutex);
  while (!board_.stopping) {
    board_.beat_cv.wait_until(lock, next_renewal, [&] {
      return board_.stopping || board_.claim_wanted;
    });
    if (board_.stopping) return;
    const bool renewal = std::chrono::steady_clock::now() >= next_renewal;
    lock.unlock();
    try {
      if (renewal) renew();
      claim();
    } catch (const std::exception& e) {
      board_.log(std::string("lease heartbeat failed, retrying: ") + e.what());
    }
    if (renewal) next_renewal = std::chrono::steady_clock::now() + period;
    lock.lock();
  }
}

}  // namespace arscout::engine::service
