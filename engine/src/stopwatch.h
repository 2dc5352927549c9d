// Wall-clock seconds for the engine's stage timings and reports.
#pragma once

#include <chrono>

namespace arscout::engine {

// Seconds of the steady clock since `start`.
inline double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
      .count();
}

}  // namespace arscout::engine
