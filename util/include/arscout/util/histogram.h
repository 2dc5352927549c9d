// A latency histogram in the Prometheus text exposition format: cumulative
// buckets, sum and count. Used by the server's and the engine's /metrics.
// Thread-safe.
#pragma once

#include <array>
#include <cstdint>
#include <mutex>
#include <string>

namespace arscout::util {

class Histogram {
 public:
  // Upper bounds, in seconds: from a millisecond (a request) to a minute
  // (an increment of a large site).
  static constexpr std::array<double, 15> kBuckets = {
      0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25,
      0.5,   1,      2.5,   5,    10,    30,   60};

  void observe(double seconds);

  // The `_bucket`, `_sum` and `_count` lines of metric `name`, each with
  // `labels` (e.g. `route="/v1/sites"`, or "" for none) before `le`.
  std::string render(const std::string& name, const std::string& labels) const;

  std::uint64_t count() const;

 private:
  mutable std::mutex mu_;
  std::array<std::uint64_t, kBuckets.size()> counts_{};
  std::uint64_t count_ = 0;
  double sum_ = 0;
};

}  // namespace arscout::util
