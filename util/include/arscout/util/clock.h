// Seconds of the steady clock, for stage timings, reports and benches: the
// one definition (it was written five times).
#pragma once

#include <chrono>

namespace arscout::util {

// Seconds of the steady clock since `start`.
inline double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
      .count();
}

}  // namespace arscout::util
