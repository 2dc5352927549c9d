#include "phase.h"

#include <chrono>

#include "site_commit.h"

namespace arscout::engine::service {

Increment run_phase(Phase& phase, SiteJob& job, util::Histogram* clock) {
  const auto start = std::chrono::steady_clock::now();
  Increment increment = phase.run(job);
  append_ready_time(increment, start);
  if (clock) clock->observe(increment.seconds);
  return increment;
}

}  // namespace arscout::engine::service
