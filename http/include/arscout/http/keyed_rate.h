// Token buckets keyed by a client (a token's name, an address): at most
// `burst` events at once and `per_hour` an hour on average, then the next
// one is refused with the seconds to wait. Uploads and new places per token
// and failed authentications per address go through one each (docs/api.md,
// "Limits"). Thread-safe; memory is bounded: buckets that are full again
// (a client quiet long enough) are forgotten when the table grows.
#pragma once

#include <chrono>
#include <cstddef>
#include <map>
#include <mutex>
#include <string>

namespace arscout::http {

class KeyedRate {
 public:
  using Clock = std::chrono::steady_clock;

  // per_hour 0: no limit (every take succeeds).
  KeyedRate(double per_hour, double burst);

  // Takes one event for `key`: 0 when it may happen, else the whole seconds
  // (>= 1) until it could, for Retry-After.
  int take(const std::string& key, Clock::time_point now = Clock::now());
  // The seconds until `key` may have one more event, without taking one:
  // 0 when it may now.
  int wait(const std::string& key, Clock::time_point now = Clock::now());

  bool limited() const { return per_second_ > 0; }
  double burst() const { return burst_; }
  double per_hour() const { return per_second_ * 3600; }

 private:
  struct Bucket {
    double tokens = 0;
    Clock::time_point at;
  };
  Bucket& refill(const std::string& key, Clock::time_point now);
  int seconds_to_one(const Bucket& b) const;
  void forget_full(Clock::time_point now);

  const double per_second_;
  const double burst_;
  std::mutex mutex_;
  std::map<std::string, Bucket> buckets_;
};

}  // namespace arscout::http
