// Built when the CUDA path is not (ARSCOUT_CUDA off): reports no device.
#ifndef ARSCOUT_HAVE_CUDA
#include <stdexcept>

#include "dense/plane_sweep_cuda.h"

namespace arscout::engine::cuda {

bool available() { return false; }
std::string device_name() { return ""; }

void sweep_planes(const DenseView&, const std::vector<const DenseView*>&,
                  const std::vector<SweepDirection>&, const PlaneSweepOptions&,
                  DepthMap*) {
  throw std::runtime_error(
      "this build has no CUDA plane sweep (configure with -DARSCOUT_CUDA=ON)");
}

}  // namespace arscout::engine::cuda
#endif
