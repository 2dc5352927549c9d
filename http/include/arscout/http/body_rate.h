// Whether a request body keeps to a minimum rate: the bytes of each window
// (10 s by default) must reach rate x the window's length. Defeats bodies
// trickled a byte at a time to hold a connection (slowloris on the body),
// which a deadline on the whole body cannot, since a large declared length
// earns a long one. Header-only; no Beast.
#pragma once

#include <chrono>
#include <cstddef>

namespace arscout::http {

class BodyRate {
 public:
  using Clock = std::chrono::steady_clock;

  // min_bytes_per_second 0: any rate.
  explicit BodyRate(std::size_t min_bytes_per_second,
                    Clock::duration window = std::chrono::seconds(10))
      : min_rate_(min_bytes_per_second), window_(window) {}

  void start(Clock::time_point now) {
    window_start_ = now;
    bytes_ = 0;
  }

  // Counts `bytes` received at `now`; false when a window just ended below
  // the minimum.
  bool add(std::size_t bytes, Clock::time_point now) {
    if (min_rate_ == 0) return true;
    bytes_ += bytes;
    const auto elapsed = now - window_start_;
    if (elapsed < window_) return true;
    const double needed = static_cast<double>(min_rate_) *
                          std::chrono::duration<double>(elapsed).count();
    const bool kept = static_cast<double>(bytes_) >= needed;
    start(now);
    return kept;
  }

  std::size_t min_rate() const { return min_rate_; }
  Clock::duration window() const { return window_; }

 private:
  std::size_t min_rate_;
  Clock::duration window_;
  Clock::time_point window_start_{};
  std::size_t bytes_ = 0;
};

}  // namespace arscout::http
