#include "thread_priority.h"

#include <exception>
#include <thread>

#ifdef __linux__
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>
#endif

namespace arscout::engine::service {

void lower_thread_priority(BackgroundLane lane) {
#ifdef __linux__
  // Under Linux's scheduler a nice-5 thread gets a third of a normal one's
  // share of a contended core, a nice-10 one a tenth.
  const int nice = lane == BackgroundLane::kPrepareAhead ? 5 : 10;
  setpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)), nice);
#else
  (void)lane;
#endif
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
