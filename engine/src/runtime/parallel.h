// Work spread over a few threads of its own, for the core's coarse tasks
// (the pairs one photo is matched with, the rows of one full match).
#pragma once

#include <cstddef>
#include <functional>

namespace arscout::engine {

// Runs `work(worker)` for worker = 0 .. workers - 1, the last on the calling
// thread and the others on threads started for the call, and returns once
// all have finished. An exception thrown by any is rethrown here (the
// lowest-numbered worker's), after every worker has stopped.
//
// Its own threads rather than OpenCV's pool: that pool runs one job at a
// time, and a call made while another thread's job holds it (a photo being
// described ahead, a dense sweep) would run on one core.
void run_workers(int workers, const std::function<void(int worker)>& work);

// Runs task(k) for k = 0 .. count - 1 on min(threads, count) workers
// (run_workers), each taking the next task not yet taken, so that unequal
// tasks still share the cores. Which worker runs a task is not fixed:
// tasks must not depend on it.
void run_tasks(std::size_t count, int threads,
               const std::function<void(std::size_t task)>& task);

}  // namespace arscout::engine
