// New coverage, the dense stage's second test of a key view: how much of
// what a view sees do the depth maps held already measure? A view whose
// picture they measure nearly everywhere brings little to the cloud and
// costs a whole sweep; on a walk of close photos most views are such.
#pragma once

#include <array>
#include <vector>

#include <Eigen/Core>
#include <Eigen/LU>

#include "arscout/engine/camera.h"
#include "arscout/engine/dense.h"

namespace arscout::engine {

// The share, in [0, 1], of a view's scene cells that `maps` measure. The
// view's photo (`camera`, original pixels; pose R, t world-to-camera) is cut
// into a grid of kCoverageColumns x kCoverageRows cells; a cell shows the
// scene when one of `keypoints` (the view's keypoints that observe sparse
// points) falls in it, so sky and blank walls ask for nothing. A cell is
// measured when depths of kCoverageMaps of the maps (every 4th pixel each
// way, in front of the view) project into it: the cloud keeps a depth only
// where another map agrees, so what one map alone sees is not in it yet.
// Distortion is ignored at this coarseness. 0 without keypoints.
double measured_share(const CameraIntrinsics& camera, const Eigen::Matrix3d& R,
                      const Eigen::Vector3d& t,
                      const std::vector<std::array<double, 2>>& keypoints,
                      const std::vector<const DepthMap*>& maps);

inline constexpr int kCoverageColumns = 16;
inline constexpr int kCoverageRows = 12;
inline constexpr int kCoverageMaps = 2;

}  // namespace arscout::engine
