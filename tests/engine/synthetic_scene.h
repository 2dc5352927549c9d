// Synthetic structure-from-motion data with exact ground truth for the
// engine's unit tests: a facade (a slab of random points a few metres deep,
// so that it is not a plane) seen by cameras on an arc in front of it, as a
// person walking around a building would take them. Everything is drawn from
// a caller's fixed-seed std::mt19937, so every test sees the same data on
// every run.
//
// The world frame is east-north-up (x east, y north, z up); poses are
// world-to-camera with OpenCV camera axes (x right, y down, z forward), as
// in the engine.
#pragma once

#include <optional>
#include <random>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "scene/scene.h"

namespace arscout::engine::synthetic {

// The camera: 1600 x 1200 pixels, focal length 1000 pixels, no distortion.
constexpr int kWidth = 1600;
constexpr int kHeight = 1200;
constexpr double kFocal = 1000;
constexpr double kCx = 800;
constexpr double kCy = 600;

struct Pose {
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();  // world-to-camera
  Eigen::Vector3d t = Eigen::Vector3d::Zero();

  Eigen::Vector3d centre() const { return -(q.conjugate() * t); }
  Eigen::Vector3d to_camera(const Eigen::Vector3d& world) const {
    return q * world + t;
  }
  Eigen::Matrix<double, 3, 4> matrix() const;
};

// A level camera at `centre` looking at `target` (image x axis horizontal).
Pose look_at(const Eigen::Vector3d& centre, const Eigen::Vector3d& target);

struct Layout {
  int images = 8;
  double arc_deg = 60;  // from the first camera to the last, about the target
  double radius_m = 15;
  int points = 300;
  // Where the points are: by default a facade 20 m wide, 12 m high and 6 m
  // deep (recesses, balconies, things in front), which fills most of each
  // frame. Points spread over the frame and in depth condition the
  // geometry: with a narrow, shallow cloud a small rotation and a small
  // translation look alike.
  Eigen::Vector3d box_min{-10.0, 10.0, 0.0};
  Eigen::Vector3d box_max{10.0, 16.0, 12.0};
};

struct Truth {
  std::vector<Pose> poses;
  std::vector<Eigen::Vector3d> points;
};

// Points uniform in the layout's box; the cameras stand 1.6 m high on a
// circle about (0, 13, 1.6), level (image x axis horizontal) and looking
// up at (0, 13, 5), as one photographs a building.
Truth make_truth(const Layout& layout, std::mt19937& rng);

// Normalized image coordinates (z = 1) of a point in front of the camera.
std::optional<Eigen::Vector2d> project_normalized(const Pose& pose,
                                                  const Eigen::Vector3d& world);
// Whether a normalized point falls inside the kWidth x kHeight image.
bool in_image(const Eigen::Vector2d& normalized);
// A uniformly random point of the image, normalized.
Eigen::Vector2d random_image_point(std::mt19937& rng);
// Isotropic Gaussian noise with this standard deviation per axis.
Eigen::Vector2d gaussian2(std::mt19937& rng, double sigma);
Eigen::Vector3d gaussian3(std::mt19937& rng, double sigma);
// A rotation by `angle_deg` about a random axis.
Eigen::Quaterniond random_rotation(std::mt19937& rng, double angle_deg);

// Correspondences between images `a` and `b` of the points both see, with
// `noise_px` of Gaussian pixel noise; a fraction `outliers` of them have the
// second point replaced by a random one.
struct TwoView {
  std::vector<Eigen::Vector2d> x1, x2;
  std::vector<bool> outlier;
  std::vector<int> point;  // index into Truth::points (-1 for an outlier)
};
TwoView make_two_view(const Truth& truth, int a, int b, double noise_px,
                      double outliers, std::mt19937& rng);

// 2D-3D correspondences for image `image`, built the same way.
struct Absolute {
  std::vector<Eigen::Vector3d> world;
  std::vector<Eigen::Vector2d> image;
  std::vector<bool> outlier;
};
Absolute make_absolute(const Truth& truth, int image, double noise_px,
                       double outliers, std::mt19937& rng);

// An engine Scene of the truth: one calibrated camera {f, f, cx, cy, 0, 0},
// every image registered at its true pose, keypoints at the projections
// plus `noise_px` of noise (and `clutter` keypoints per image that observe
// nothing), unit random descriptors and colours, points at their true
// positions with full tracks. The gauge: image 0 is the reference, image 1
// fixes the scale.
Scene make_scene(const Truth& truth, double noise_px, int clutter,
                 std::mt19937& rng);

// Angle in degrees of the rotation between two rotations.
double rotation_error_deg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b);
// Angle in degrees between two directions.
double direction_error_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b);
// Per-axis RMS of the reprojection errors over every observation, pixels.
double reprojection_rms_px(const Scene& scene);

}  // namespace arscout::engine::synthetic
