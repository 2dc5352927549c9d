#include "thread_priority.h"

#include <exception>
#include <thread>

#include "arscout/util/process.h"

namespace arscout::engine::service {

void lower_thread_priority(BackgroundLane lane) {
  util::set_thread_nice(lane == BackgroundLane::kPrepareAhead ? 5 : 10);
}

void run_at_lane_priority(BackgroundLane lane,
                          const std::function<void()>& work) {
  std::exception_ptr error;
  std::thread low([&] {
    lower_thread_priority(lane);
    try {
      work();
    } catch (...) {
      error = std::current_exception();
    }
  });
  low.join();
  if (error) std::rethrow_exception(error);
}

}  // namespace arscout::engine::service
