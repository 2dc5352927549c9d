#include "arscout/http/keyed_limit.h"

namespace arscout::http {

struct KeyedLimit::Slot::State {
  std::mutex mu;
  std::size_t total = 0;
  std::map<std::string, std::size_t> per_key;
};

KeyedLimit::KeyedLimit(std::size_t total, std::size_t per_key)
    : total_(total),
      per_key_(per_key),
      state_(std::make_shared<Slot::State>()) {}

KeyedLimit::Slot::Slot(std::shared_ptr<State> state, std::string key)
    : state_(std::move(state)), key_(std::move(key)) {}

KeyedLimit::Slot& KeyedLimit::Slot::operator=(Slot&& other) noexcept {
  if (this != &other) {
    release();
    state_ = std::move(other.state_);
    key_ = std::move(other.key_);
  }
  return *this;
}

void KeyedLimit::Slot::release() {
  if (!state_) return;  // moved from
  const std::shared_ptr<State> state = std::move(state_);
  std::lock_guard lock(state->mu);  // released before `state` goes
  --state->total;
  auto it = state->per_key.find(key_);
  if (it != state->per_key.end() && --it->second == 0) state->per_key.erase(it);
}

std::optional<KeyedLimit::Slot> KeyedLimit::acquire(const std::string& key) {
  std::lock_guard lock(state_->mu);
  auto it = state_->per_key.find(key);
  const std::size_t held = it == state_->per_key.end() ? 0 : it->second;
  if ((total_ > 0 && state_->total >= total_) ||
      (per_key_ > 0 && held >= per_key_))
    return std::nullopt;
  ++state_->total;
  ++state_->per_key[key];
  return Slot(state_, key);
}

std::size_t KeyedLimit::in_use() const {
  std::lock_guard lock(state_->mu);
  return state_->total;
}

std::size_t KeyedLimit::in_use(const std::string& key) const {
  std::lock_guard lock(state_->mu);
  auto it = state_->per_key.find(key);
  return it == state_->per_key.end() ? 0 : it->second;
}

}  // namespace arscout::http
