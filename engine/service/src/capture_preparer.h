// Photos prepared ahead of their increments. A site's increments run one
// at a time, and each photo's decode, undistortion and features (a fifth of
// its sparse time, and independent of the model) used to run inside them:
// with several scouts the next photos waited for the model to take in the
// ones before and then for their own features. The preparer makes them on a
// thread of its own as soon as a capture is queued (Reconstruction's
// prepare_capture), so an increment starts with them ready, while the
// model's work and the preparation share the cores.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "arscout/engine/reconstruction.h"

namespace arscout::engine::service {

class CapturePreparer {
 public:
  // Reads what the engine takes from a stored capture, its photo's bytes
  // with it; throws when it cannot.
  using ReadInput = std::function<CaptureInput(const std::string& capture)>;

  struct Prepared {
    std::string image_bytes;  // for the case the site prepares it again
    PreparedCapture photo;
  };

  // Holds at most `capacity` prepared photos not yet taken; a prepared
  // photo nobody takes within `stale_after` (its site went to another
  // worker, it was withdrawn) is dropped when room is needed.
  CapturePreparer(ReadInput read_input, ReconstructionOptions options,
                  std::size_t capacity = 16,
                  std::chrono::seconds stale_after = std::chrono::seconds(60));
  ~CapturePreparer();  // stops the thread; what it holds is dropped
  CapturePreparer(const CapturePreparer&) = delete;
  CapturePreparer& operator=(const CapturePreparer&) = delete;

  // Queues a capture (once; again while queued or held: nothing).
  void want(const std::string& capture);

  // The capture prepared: waits while it is being prepared. nullopt when
  // it was never wanted, failed (the caller's own attempt then gives the
  // error), or is still queued, which it then leaves: the caller prepares
  // it itself rather than wait its turn.
  std::optional<Prepared> take(const std::string& capture);

  // Drops what is queued and held and waits for the photo being prepared:
  // from its return until the next want() the preparer reads nothing (the
  // worker's stop(): the store may go away after it).
  void clear();

  struct Counts {
    std::int64_t prepared = 0;  // made
    std::int64_t taken = 0;     // of those, used by an increment
    std::int64_t missed = 0;    // take() found it not ready
    std::int64_t dropped = 0;   // stale, or failed
  };
  Counts counts() const;

 private:
  struct Held {
    Prepared prepared;
    std::chrono::steady_clock::time_point at;
  };
  void run();
  bool room(std::unique_lock<std::mutex>& lock);
  void prepare(const std::string& capture, std::unique_lock<std::mutex>& lock);

  const ReadInput read_input_;
  const ReconstructionOptions options_;
  const std::size_t capacity_;
  const std::chrono::seconds stale_after_;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<std::string> queued_;
  std::string working_on_;
  std::map<std::string, Held> held_;
  Counts counts_;
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace arscout::engine::service
