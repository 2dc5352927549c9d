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

// A pinhole camera: intrinsics K, world-to-camera R and t, image size.
struct PinholeView {
  Eigen::Matrix3d K = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  cv::Size size;
};

// A view of the whole cloud from outside, for reports: the camera looks at
// the cloud's median point from `azimuth_deg` (clockwise from +y, north in
// an ENU frame) and `elevation_deg` above the x-y plane (clamped to
// [-89, 89]), with +z up in the image, a 60-degree horizontal field of view,
// and far enough back that the nearest 95 % of the points around the
// median fit the frame. Throws std::invalid_argument for an empty cloud or
// an empty size.
PinholeView orbit_view(const std::vector<ColoredPoint>& points,
                       double azimuth_deg, double elevation_deg, cv::Size size);

}  // namespace arscout::engine
