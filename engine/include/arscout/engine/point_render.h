// Drawing a coloured point cloud into a pinhole view on the CPU: z-buffered
// square splats, no GPU. Used to compare a fused cloud with a photo it was
// not built from, and by offline rendering and overlays.
#pragma once

#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "arscout/engine/ply.h"

namespace arscout::engine {

struct PointRendering {
  cv::Mat bgr;    // CV_8UC3, black where no point lands
  cv::Mat depth;  // CV_32F, camera z of the nearest point, 0 where none
};

// Projects every point (world frame) through K [R | t] and keeps, per
// pixel, the nearest; each point covers the (2 radius + 1)^2 pixels around
// its projection. Points behind the camera or outside the image are
// skipped.
PointRendering render_points(const std::vector<ColoredPoint>& points,
                             const Eigen::Matrix3d& K, const Eigen::Matrix3d& R,
                             const Eigen::Vector3d& t, cv::Size size,
                             int radius = 1);

}  // namespace arscout::engine
