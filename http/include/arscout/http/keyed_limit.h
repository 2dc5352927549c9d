// A count of holders in total and per key (a token, a client address) that
// refuses one past either cap: open streams per token, connections per
// address. Thread-safe; a slot may outlive the limit that gave it.
#pragma once

#include <cstddef>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

namespace arscout::http {

class KeyedLimit {
 public:
  // 0 for either cap: no cap of that kind.
  KeyedLimit(std::size_t total, std::size_t per_key);

  // Held while the thing counted exists; released when destroyed.
  class Slot {
   public:
    Slot(Slot&&) noexcept = default;
    Slot& operator=(Slot&& other) noexcept;
    ~Slot() { release(); }

   private:
    friend class KeyedLimit;
    struct State;
    Slot(std::shared_ptr<State> state, std::string key);
    void release();
    std::shared_ptr<State> state_;
    std::string key_;
  };

  // nullopt when the total or the key's cap is reached.
  std::optional<Slot> acquire(const std::string& key);
  std::size_t in_use() const;
  std::size_t in_use(const std::string& key) const;
  std::size_t total_cap() const { return total_; }
  std::size_t per_key_cap() const { return per_key_; }

 private:
  std::size_t total_;
  std::size_t per_key_;
  std::shared_ptr<Slot::State> state_;
};

}  // namespace arscout::http
