// The CUDA plane sweep: the same algorithm as the CPU path in
// plane_sweep.cpp (same directions, planes, window, aggregation and
// rejection), built only with -DARSCOUT_CUDA=ON. Without it, available()
// is false and the CPU path runs.
#pragma once

#include <string>
#include <vector>

#include "arscout/engine/dense.h"

namespace arscout::engine::cuda {

// True when this build has the CUDA path and a CUDA device is present.
bool available();
// The device in words ("" when none), for logs and test messages.
std::string device_name();

// Fills `map` (already sized, zeroed) like the CPU sweep. Throws
// std::runtime_error on a CUDA error or when the path is not built.
void sweep_planes(const DenseView& key,
                  const std::vector<const DenseView*>& neighbours,
                  const std::vector<SweepDirection>& directions,
                  const PlaneSweepOptions& options, DepthMap* map);

}  // namespace arscout::engine::cuda
