// Wall-clock seconds for the engine's stage timings and reports.
#pragma once

#include <chrono>

namespace arscout::engine {

// Seconds of the steady clock since `start`.
inline double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
      .count();
}

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
