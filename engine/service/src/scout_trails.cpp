#include "scout_trails.h"

#include <cstdlib>

namespace arscout::engine::service {
namespace {

// Placed photos remembered per scout: a walk's last hour or so.
constexpr std::size_t kPlacedKept = 512;

}  // namespace

void ScoutTrails::placed(const std::string& scout, std::int64_t taken_s,
                         const std::string& site) {
  auto& trail = placed_[scout];
  trail.emplace(taken_s, site);
  if (trail.size() > kPlacedKept) trail.erase(trail.begin());
}

std::optional<std::string> ScoutTrails::site_near(const std::string& scout,
                                                  std::int64_t taken_s) const {
  const auto trail = placed_.find(scout);
  if (trail == placed_.end()) return std::nullopt;
  std::optional<std::string> best;
  std::int64_t best_gap = window_s_ + 1;
  // The nearest on either side of taken_s.
  auto after = trail->second.lower_bound(taken_s);
  for (auto it : {after, after == trail->second.begin() ? trail->second.end()
                                                        : std::prev(after)}) {
    if (it == trail->second.end()) continue;
    const std::int64_t gap = std::llabs(it->first - taken_s);
    if (gap < best_gap) {
      best_gap = gap;
      best = it->second;
    }
  }
  return best;
}

void ScoutTrails::wait(const std::string& scout, std::int64_t taken_s,
                       const std::string& id) {
  waiting_[scout][id] = taken_s;
}

std::vector<std::string> ScoutTrails::release(const std::string& scout,
                                              std::int64_t taken_s) {
  std::vector<std::string> released;
  const auto waiting = waiting_.find(scout);
  if (waiting == waiting_.end()) return released;
  for (auto it = waiting->second.begin(); it != waiting->second.end();) {
    if (std::llabs(it->second - taken_s) <= window_s_) {
      released.push_back(it->first);
      it = waiting->second.erase(it);
    } else {
      ++it;
    }
  }
  return released;
}

}  // namespace arscout::engine::service
