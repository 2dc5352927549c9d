// Evaluation of a dense point cloud: against a scene's exact surfaces
// (accuracy and completeness, for the rendered scenes), and by plausibility
// alone (for real scenes, where the truth is not known).
//
// The surfaces are planar parallelograms (the synthetic renderer's quads);
// the views that "see" a surface are given as exact depth images, so that
// occlusion is the renderer's own. Everything here is in the truth's frame
// and units (metres): align a reconstruction to the truth first (see
// model_eval.h, compare_to_ground_truth).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace arscout::eval {

// corner + s * edge_u + t * edge_v, s, t in [0, 1].
struct Parallelogram {
  Eigen::Vector3d corner = Eigen::Vector3d::Zero();
  Eigen::Vector3d edge_u = Eigen::Vector3d::UnitX();
  Eigen::Vector3d edge_v = Eigen::Vector3d::UnitY();
};

// The distance from p to the nearest point of one parallelogram (its inside
// or its border). A degenerate one (parallel edges) counts as its edges.
double distance_to(const Parallelogram& surface, const Eigen::Vector3d& p);

// The distance from a point to the nearest of many surfaces. Surfaces are
// screened by their bounding boxes, so a point costs a box test per surface
// and an exact distance for the few that could be nearest.
class SurfaceDistance {
 public:
  explicit SurfaceDistance(std::vector<Parallelogram> surfaces);
  // Infinity when there are no surfaces.
  double operator()(const Eigen::Vector3d& p) const;

 private:
  std::vector<Parallelogram> surfaces_;
  std::vector<Eigen::Vector3d> box_min_, box_max_;
};

struct AccuracyFigures {
  int points = 0;
  double median_m = 0;  // distance to the nearest true surface
  double p90_m = 0;
  double within_share = 0;  // of the points, within `tolerance_m`
};

// Each point's distance to the true surfaces: median, 90th percentile
// (linear interpolation, as eval::percentile) and the share within
// `tolerance_m`. Zeros for no points.
AccuracyFigures measure_accuracy(const std::vector<Eigen::Vector3d>& points,
                                 const SurfaceDistance& truth,
                                 double tolerance_m = 0.05);

// A view of the truth: pinhole intrinsics and a world-to-camera pose
// (x_cam = R x_world + t, OpenCV axes), and the exact depth (camera z) of
// the surface each pixel's centre sees, row-major, 0 where it sees none.
struct DepthView {
  Eigen::Matrix3d K = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  int width = 0, height = 0;
  std::vector<float> depth;
};

struct CompletenessOptions {
  double spacing_m = 0.05;    // the surfaces are sampled on this grid
  double tolerance_m = 0.05;  // a sample is covered by a point this near
  int min_views = 2;          // a sample counts when this many views see it
  // A view sees a sample when the sample is inside its picture, in front,
  // not hidden (its depth within max(1 %, 2 cm) of the depth image's) and
  // resolved: a pixel of the dense working resolution, of focal length
  // `footprint_focal_px`, covers at most `max_footprint_m` of the surface
  // there (depth / (focal * cos(incidence))). A surface seen only from far
  // or at a grazing angle is not asked of the cloud. 0: no such limit.
  double footprint_focal_px = 0;
  double max_footprint_m = 0.05;
};

// Samples seen by this many views or more share the last count of
// CompletenessFigures' by-views split.
constexpr int kMostViewsCounted = 8;

struct CompletenessFigures {
  int64_t samples = 0;  // on all surfaces
  int64_t seen = 0;     // seen by at least min_views views
  int64_t covered = 0;  // of those, with a point within tolerance_m
  double share = 0;     // covered / seen (0 when none is seen)
  // The seen and covered samples split by how many views see them ([k]:
  // k views, [kMostViewsCounted]: that many or more): where a cloud's gaps
  // are, surface few views see or surface many do. Each sums to seen and
  // covered.
  std::array<int64_t, kMostViewsCounted + 1> seen_by_views{};
  std::array<int64_t, kMostViewsCounted + 1> covered_by_views{};
};

// The share of the true surface seen by at least `min_views` of `views`
// that lies within `tolerance_m` of a point of the cloud.
CompletenessFigures measure_completeness(
    const std::vector<Parallelogram>& surfaces,
    const std::vector<DepthView>& views,
    const std::vector<Eigen::Vector3d>& points,
    const CompletenessOptions& options = {});

// --- plausibility: real scenes without a truth -------------------------------

struct CloudPoint {
  Eigen::Vector3d xyz = Eigen::Vector3d::Zero();  // east-north-up, metres
  uint8_t r = 0, g = 0, b = 0;
  uint8_t support = 0;  // depth maps that measured it (0: unknown)
};

// Sky-coloured: hue 190-250 degrees (blue), saturation at least 0.12 and
// value at least 0.55 (HSV of the 0-255 channels). Clear and hazy sky;
// overcast white is not told apart from a white wall, and a blue facade
// counts as sky.
bool sky_coloured(uint8_t r, uint8_t g, uint8_t b);

struct PlausibilityOptions {
  double max_horizontal_m = 40;  // from the point's nearest camera
  double max_above_m = 30;
  double max_below_m = 6;
};

struct PlausibilityFigures {
  int points = 0;
  // Shares of the points; one point may be in several. The nearest camera
  // is the nearest horizontally (east-north).
  double far_share = 0;          // more than max_horizontal_m away
  double above_share = 0;        // more than max_above_m above it
  double below_share = 0;        // more than max_below_m below it
  double sky_share = 0;          // sky_coloured
  double implausible_share = 0;  // in any of the four
};

// The points that cannot be part of a street scouted from `cameras`
// (camera centres, east-north-up). Throws std::invalid_argument when there
// are points but no cameras.
PlausibilityFigures measure_plausibility(
    const std::vector<CloudPoint>& points,
    const std::vector<Eigen::Vector3d>& cameras,
    const PlausibilityOptions& options = {});

// The ground the cloud covers near the cameras, in square metres: the
// camera height is the most common drop from a point's nearest camera
// (horizontally) to the point, in 10 cm bins from 0.8 to 4 m; the points
// within `band_m` of that drop are counted on a grid of `cell_m` cells, and
// the covered cells' area is returned. 0 when no point lies in that range.
double ground_cover_m2(const std::vector<CloudPoint>& points,
                       const std::vector<Eigen::Vector3d>& cameras,
                       double cell_m = 0.05, double band_m = 0.15);

}  // namespace arscout::eval
