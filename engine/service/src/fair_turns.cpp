#include "fair_turns.h"

#include <algorithm>
#include <limits>
#include <map>
#include <string>

namespace arscout::engine::service {

std::vector<Work> take_in_turns(std::deque<Work>& pending, std::size_t limit) {
  limit = std::max<std::size_t>(limit, 1);
  // Each scout's queue, by position in `pending`; scouts in order of their
  // oldest (first seen in arrival order).
  std::vector<std::string> scouts;
  std::map<std::string, std::vector<std::size_t>> queues;
  for (std::size_t i = 0; i < pending.size(); ++i) {
    auto [it, fresh] = queues.try_emplace(pending[i].scout);
    if (fresh) scouts.push_back(pending[i].scout);
    it->second.push_back(i);
  }
  std::vector<std::size_t> order;
  for (std::size_t round = 0; order.size() < limit; ++round) {
    bool any = false;
    for (const std::string& scout : scouts) {
      const std::vector<std::size_t>& queue = queues[scout];
      if (round >= queue.size() || order.size() == limit) continue;
      order.push_back(queue[round]);
      any = true;
    }
    if (!any) break;
  }
  std::vector<Work> taken;
  taken.reserve(order.size());
  for (std::size_t i : order) taken.push_back(pending[i]);
  std::vector<bool> gone(pending.size(), false);
  for (std::size_t i : order) gone[i] = true;
  std::deque<Work> left;
  for (std::size_t i = 0; i < pending.size(); ++i)
    if (!gone[i]) left.push_back(std::move(pending[i]));
  pending = std::move(left);
  return taken;
}

std::int64_t settled_through(const std::vector<Work>& taken,
                             const std::deque<Work>& left) {
  std::int64_t through = 0;
  for (const Work& w : taken) through = std::max(through, w.seq);
  std::int64_t oldest_left = std::numeric_limits<std::int64_t>::max();
  for (const Work& w : left) oldest_left = std::min(oldest_left, w.seq);
  return std::min(through, oldest_left - 1);
}

}  // namespace arscout::engine::service
