// Geometric estimators, each robust (RANSAC) where its input has outliers.
// Image points are normalized camera coordinates (z = 1), so thresholds are
// angles-ish: pixels divided by the focal length.
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace arscout::engine {

// --- Relative pose (5-point essential matrix in RANSAC) ---------------------
struct RelativePose {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();  // x2 = R x1 + t
  Eigen::Vector3d t = Eigen::Vector3d::Zero();      // unit length
  std::vector<int> inliers;     // indices of inlier correspondences
  double median_angle_deg = 0;  // triangulation angle over the inliers
  double homography_ratio = 0;  // homography / essential RANSAC inliers
};
// nullopt when fewer than `min_inliers` correspondences agree. Where a
// plane holds most matches, the poses its homography decomposes into are
// candidates too, and the one with the most matches in front of both
// cameras wins (a wall's twin pose can satisfy RANSAC; docs/engine.md,
// "Planar scenes").
std::optional<RelativePose> estimate_relative_pose(
    const std::vector<Eigen::Vector2d>& x1,
    const std::vector<Eigen::Vector2d>& x2, double threshold, int min_inliers);

// The first-order (Sampson) distance of a correspondence x1 <-> x2 to an
// essential matrix E, from E x1, E^T x2 and x2 (homogeneous, last entry
// 1): the epipolar error over the norm of its gradient, as OpenCV's
// essential-matrix RANSAC measures it. One formula for the inlier test and
// the two-view refinement (templated for Ceres' Jets); the sign is that of
// x2^T E x1, and only its square means anything.
template <typename T>
T sampson_distance(const T* e_x1, const T* et_x2, const T* x2) {
  using std::sqrt;
  const T epipolar = x2[0] * e_x1[0] + x2[1] * e_x1[1] + x2[2] * e_x1[2];
  const T norm2 = e_x1[0] * e_x1[0] + e_x1[1] * e_x1[1] + et_x2[0] * et_x2[0] +
                  et_x2[1] * et_x2[1];
  return epipolar / sqrt(norm2 + T(1e-30));
}

// --- Absolute pose (P3P in RANSAC, then refinement on the inliers) ---------
struct AbsolutePose {
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();  // world-to-camera
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  std::vector<int> inliers;
};
std::optional<AbsolutePose> estimate_absolute_pose(
    const std::vector<Eigen::Vector3d>& world,
    const std::vector<Eigen::Vector2d>& image, double threshold,
    int min_inliers);

// How well a set of 2D-3D correspondences pins a pose down: the standard
// deviations (largest over the axes) of the rotation, radians, and of the
// translation, world units, from the reprojection errors' Gauss-Newton
// information at the pose, each marginal (the other free), for image
// noise `image_sigma` in normalized units. Points on one small patch leave
// a rotation trading against a translation: a large rotation sigma. Both
// are infinite when the correspondences do not constrain the pose at all.
struct PoseUncertainty {
  double rotation_sigma_rad = std::numeric_limits<double>::infinity();
  double translation_sigma = std::numeric_limits<double>::infinity();
};
PoseUncertainty pose_uncertainty(const Eigen::Quaterniond& q,
                                 const Eigen::Vector3d& t,
                                 const std::vector<Eigen::Vector3d>& world,
                                 double image_sigma);

// --- Triangulation ----------------------------------------------------------
// Linear (DLT) triangulation from two or more views, each a world-to-camera
// [R | t] and a normalized image point. nullopt when degenerate (rays that
// coincide or are parallel) or when the point is not in front of every
// camera.
std::optional<Eigen::Vector3d> triangulate(
    const std::vector<Eigen::Matrix<double, 3, 4>>& poses,
    const std::vector<Eigen::Vector2d>& points);
// Angle in degrees at `point` between the rays from two camera centres.
double triangulation_angle_deg(const Eigen::Vector3d& centre1,
                               const Eigen::Vector3d& centre2,
                               const Eigen::Vector3d& point);

// --- Similarity (Umeyama in RANSAC) -----------------------------------------
struct Similarity {
  double scale = 1;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  Eigen::Vector3d apply(const Eigen::Vector3d& x) const {
    return scale * (R * x) + t;
  }
  // The similarity that undoes this one.
  Similarity inverse() const {
    Similarity result;
    result.scale = 1 / scale;
    result.R = R.transpose();
    result.t = -result.scale * (result.R * t);
    return result;
  }
};
// Least-squares similarity from >= 3 point pairs (Umeyama, 1991).
std::optional<Similarity> fit_similarity(
    const std::vector<Eigen::Vector3d>& from,
    const std::vector<Eigen::Vector3d>& to);
// Robust version: minimal samples of 3 drawn with a generator seeded by
// `seed`, inliers within `threshold` (in `to` units), then a refit on all
// inliers. nullopt when fewer than 3 points agree.
std::optional<Similarity> estimate_similarity(
    const std::vector<Eigen::Vector3d>& from,
    const std::vector<Eigen::Vector3d>& to, double threshold, uint64_t seed,
    std::vector<int>* inliers);

// --- Rotation between two sets of rays (Kabsch in RANSAC) -------------------
// The rotation R with to[i] ~ R from[i] for unit rays (a camera turning on
// the spot): samples of 2 drawn with a generator seeded by `seed`, inliers
// within `threshold_rad` of angle, then a least-squares refit on them.
// nullopt when fewer than `min_inliers` agree.
std::optional<Eigen::Matrix3d> estimate_rotation(
    const std::vector<Eigen::Vector3d>& from,
    const std::vector<Eigen::Vector3d>& to, double threshold_rad,
    int min_inliers, uint64_t seed, std::vector<int>* inliers);

}  // namespace arscout::engine
