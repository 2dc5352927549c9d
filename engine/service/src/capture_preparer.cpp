#include "capture_preparer.h"

#include <algorithm>
#include <exception>
#include <utility>

#include "thread_priority.h"

namespace arscout::engine::service {

CapturePreparer::CapturePreparer(ReadInput read_input,
                                 ReconstructionOptions options,
                                 std::size_t capacity,
                                 std::chrono::seconds stale_after)
    : read_input_(std::move(read_input)),
      options_(std::move(options)),
      capacity_(std::max<std::size_t>(1, capacity)),
      stale_after_(stale_after),
      thread_([this] { run(); }) {}

CapturePreparer::~CapturePreparer() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  changed_.notify_all();
  thread_.join();
}

void CapturePreparer::want(const std::string& capture) {
  {
    std::lock_guard lock(mutex_);
    if (working_on_ == capture || held_.count(capture) ||
        std::find(queued_.begin(), queued_.end(), capture) != queued_.end())
      return;
    queued_.push_back(capture);
  }
  changed_.notify_all();
}

std::optional<CapturePreparer::Prepared> CapturePreparer::take(
    const std::string& capture) {
  std::unique_lock lock(mutex_);
  changed_.wait(lock, [&] { return stopping_ || working_on_ != capture; });
  auto it = held_.find(capture);
  if (it == held_.end()) {
    auto queued = std::find(queued_.begin(), queued_.end(), capture);
    if (queued != queued_.end()) {
      queued_.erase(queued);
      ++counts_.missed;
    }
    return std::nullopt;
  }
  Prepared prepared = std::move(it->second.prepared);
  held_.erase(it);
  ++counts_.taken;
  changed_.notify_all();  // room for the next
  return prepared;
}

void CapturePreparer::clear() {
  std::unique_lock lock(mutex_);
  queued_.clear();
  changed_.wait(lock, [&] { return working_on_.empty(); });
  held_.clear();
}

CapturePreparer::Counts CapturePreparer::counts() const {
  std::lock_guard lock(mutex_);
  return counts_;
}

// True when one more may be held: below capacity, or after dropping the
// oldest held photo that nobody took in time.
bool CapturePreparer::room(std::unique_lock<std::mutex>& lock) {
  (void)lock;  // held by the caller
  if (held_.size() < capacity_) return true;
  auto oldest = std::min_element(
      held_.begin(), held_.end(),
      [](const auto& a, const auto& b) { return a.second.at < b.second.at; });
  if (std::chrono::steady_clock::now() - oldest->second.at < stale_after_)
    return false;
  held_.erase(oldest);
  ++counts_.dropped;
  return true;
}

void CapturePreparer::run() {
  // Ahead of the increments, not in their way: a photo this thread has not
  // reached is prepared by its increment (thread_priority.h).
  lower_thread_priority(BackgroundLane::kPrepareAhead);
  std::unique_lock lock(mutex_);
  while (true) {
    changed_.wait_for(lock, std::chrono::seconds(1), [&] {
      return stopping_ || (!queued_.empty() && held_.size() < capacity_);
    });
    if (stopping_) return;
    if (queued_.empty() || !room(lock)) continue;
    const std::string capture = queued_.front();
    queued_.pop_front();
    prepare(capture, lock);
  }
}

// Prepares one capture with the lock released; a failure is left for the
// increment to meet again and report.
void CapturePreparer::prepare(const std::string& capture,
                              std::unique_lock<std::mutex>& lock) {
  working_on_ = capture;
  lock.unlock();
  std::optional<Prepared> made;
  try {
    CaptureInput input = read_input_(capture);
    Prepared prepared;
    prepared.photo = prepare_capture(input, options_);
    prepared.image_bytes = std::move(input.image_bytes);
    made = std::move(prepared);
  } catch (const std::exception&) {
    made.reset();
  }
  lock.lock();
  working_on_.clear();
  if (made) {
    held_[capture] = Held{std::move(*made), std::chrono::steady_clock::now()};
    ++counts_.prepared;
  } else {
    ++counts_.dropped;
  }
  changed_.notify_all();
}

}  // namespace arscout::engine::service
