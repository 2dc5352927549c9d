// Which of a site's queued captures the next increment takes: scouts take
// turns, so one scout's burst (a phone that was offline, a folder sent at
// once) never starves another scout's photos. Each scout's own captures
// keep their order (a withdrawal stays after its capture).
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <vector>

#include "site_job.h"

namespace arscout::engine::service {

// Removes up to `limit` works from `pending` (in the order they arrived)
// and returns them in the order to run: the scouts in the order of their
// oldest waiting work, one work each per round, each scout's oldest first.
// `limit` < 1 takes one.
std::vector<Work> take_in_turns(std::deque<Work>& pending, std::size_t limit);

// The seq at or below which every change is settled once `taken` has run,
// with `left` still queued: for SiteJob::run's `settled_through`.
std::int64_t settled_through(const std::vector<Work>& taken,
                             const std::deque<Work>& left);

}  // namespace arscout::engine::service
