// Surface normals of a depth map, for the fused cloud's points
// (map_fusion.h).
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace arscout::engine {

// The surface normal at each pixel of `depth` (CV_32F, 0 = none), in the
// camera frame and turned toward the camera: the plane fitted by least
// squares to the inverse depths of the pixels with a depth in the
// (2 radius + 1)^2 window around it (on a plane n . X = d, 1/z =
// (K^-T n) . (x, y, 1) / d is linear in the pixel, so the fit is exact
// there and averages the sweep's depth noise elsewhere). CV_32FC3; zero
// where the pixel has no depth or fewer than half the window has one.
// Box filters: the cost does not grow with the radius.
cv::Mat depth_normals(const cv::Mat& depth, const Eigen::Matrix3d& K,
                      int radius);

}  // namespace arscout::engine
