// The worker's lanes in the order the CPU serves them: a scout waits on
// the sparse increments (normal priority), which take what was prepared
// ahead, and the dense cloud comes after both.
#pragma once

#include <functional>

namespace arscout::engine::service {

enum class BackgroundLane {
  kPrepareAhead,  // photos decoded and described before their increment
  kDense,         // depth maps and the fused cloud
};

// Lowers the calling thread's priority to its lane's (a nice value, per
// thread on Linux; elsewhere nothing). Work a thread hands to OpenCV's pool
// runs at the pool's priority.
void lower_thread_priority(BackgroundLane lane);

// Runs `work` on a thread of its own at `lane`'s priority, and returns once
// it has finished, rethrowing what it threw. For a lane whose own thread
// also takes locks that the sparse lane waits on: only the part that holds
// none runs low, so that a low-priority holder never keeps the sparse lane
// waiting (a priority inversion).
void run_at_lane_priority(BackgroundLane lane,
                          const std::function<void()>& work);

}  // namespace arscout::engine::service
