#include "arscout/http/keyed_rate.h"

#include <algorithm>
#include <cmath>
#include <iterator>

namespace arscout::http {
namespace {

// Past this many clients, the full buckets are dropped (they hold nothing
// a fresh bucket would not).
constexpr std::size_t kForgetAbove = 4096;

}  // namespace

KeyedRate::KeyedRate(double per_hour, double burst)
    : per_second_(std::max(0.0, per_hour) / 3600),
      burst_(std::max(1.0, burst)) {}

KeyedRate::Bucket& KeyedRate::refill(const std::string& key,
                                     Clock::time_point now) {
  auto [it, fresh] = buckets_.try_emplace(key, Bucket{burst_, now});
  Bucket& b = it->second;
  if (!fresh) {
    const double seconds = std::chrono::duration<double>(now - b.at).count();
    b.tokens =
        std::min(burst_, b.tokens + std::max(0.0, seconds) * per_second_);
    b.at = now;
  }
  return b;
}

int KeyedRate::seconds_to_one(const Bucket& b) const {
  if (b.tokens >= 1) return 0;
  return std::max(1, static_cast<int>(std::ceil((1 - b.tokens) / per_second_)));
}

void KeyedRate::forget_full(Clock::time_point now) {
  if (buckets_.size() <= kForgetAbove) return;
  for (auto it = buckets_.begin(); it != buckets_.end();) {
    const double seconds =
        std::chrono::duration<double>(now - it->second.at).count();
    const bool full = it->second.tokens + seconds * per_second_ >= burst_;
    it = full ? buckets_.erase(it) : std::next(it);
  }
  // Still more clients than that are active (an attacker with many
  // addresses): start again rather than grow.
  if (buckets_.size() > 4 * kForgetAbove) buckets_.clear();
}

int KeyedRate::take(const std::string& key, Clock::time_point now) {
  if (!limited()) return 0;
  std::lock_guard lock(mutex_);
  forget_full(now);
  Bucket& b = refill(key, now);
  const int wait = seconds_to_one(b);
  if (wait == 0) b.tokens -= 1;
  return wait;
}

int KeyedRate::wait(const std::string& key, Clock::time_point now) {
  if (!limited()) return 0;
  std::lock_guard lock(mutex_);
  auto it = buckets_.find(key);
  if (it == buckets_.end()) return 0;
  return seconds_to_one(refill(key, now));
}

}  // namespace arscout::http
