// Wall-clock seconds for the engine's stage timings and reports.
#pragma once

#include <chrono>

#include "arscout/util/clock.h"

namespace arscout::engine {

using util::seconds_since;

// Adds the seconds of its lifetime to a stage's total.
class StageClock {
 public:
  explicit StageClock(double& total)
      : total_(total), start_(std::chrono::steady_clock::now()) {}
  ~StageClock() { total_ += seconds_since(start_); }
  StageClock(const StageClock&) = delete;
  StageClock& operator=(const StageClock&) = delete;

 private:
  double& total_;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace arscout::engine
