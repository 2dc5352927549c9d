// A count of bytes in flight with a cap, shared by every connection: the
// pieces of streamed bodies (blobs, exports) that are read and not yet
// written. A piece that would pass the cap waits; holding the cap keeps a
// few hundred slow readers of large blobs from taking gigabytes.
// Thread-safe.
#pragma once

#include <atomic>
#include <cstddef>
#include <optional>
#include <utility>

namespace arscout::http {

class ByteBudget {
 public:
  // cap 0: no cap.
  explicit ByteBudget(std::size_t cap) : cap_(cap) {}

  // Bytes taken from the budget, given back when destroyed.
  class Hold {
   public:
    Hold(Hold&& other) noexcept
        : budget_(std::exchange(other.budget_, nullptr)),
          bytes_(other.bytes_) {}
    Hold& operator=(Hold&&) = delete;
    ~Hold() {
      if (budget_) budget_->in_use_.fetch_sub(bytes_);
    }

   private:
    friend class ByteBudget;
    Hold(ByteBudget* budget, std::size_t bytes)
        : budget_(budget), bytes_(bytes) {}
    ByteBudget* budget_;
    std::size_t bytes_;
  };

  // nullopt when taking `bytes` would pass the cap; a request larger than
  // the whole cap is granted only while nothing else is held.
  std::optional<Hold> take(std::size_t bytes) {
    std::size_t used = in_use_.load();
    do {
      if (cap_ > 0 && used > 0 && used + bytes > cap_) return std::nullopt;
    } while (!in_use_.compare_exchange_weak(used, used + bytes));
    return Hold(this, bytes);
  }
  std::size_t in_use() const { return in_use_.load(); }
  std::size_t cap() const { return cap_; }

 private:
  const std::size_t cap_;
  std::atomic<std::size_t> in_use_{0};
};

}  // namespace arscout::http
