// Which planes to sweep: the depth range and plane count from the key
// view's sparse points and its neighbours' baselines, and the dominant scene
// plane orientations (facades, ground) found among those points by
// sequential RANSAC, and the ground when the world's up is known.
#include <algorithm>
#include <cmath>
#include <optional>
#include <random>

#include <Eigen/Dense>

#include "arscout/engine/dense.h"

namespace arscout::engine {
namespace {

constexpr int kMinSparsePoints = 8;

double percentile(std::vector<double> values, double p) {
  const size_t k =
      std::min(values.size() - 1, static_cast<size_t>(p * (values.size() - 1)));
  std::nth_element(values.begin(), values.begin() + k, values.end());
  return values[k];
}

std::vector<Eigen::Vector3d> in_key_frame(const DenseView& key) {
  std::vector<Eigen::Vector3d> points;
  for (const Eigen::Vector3d& X : key.sparse_points) {
    const Eigen::Vector3d c = key.R * X + key.t;
    if (c.z() > 0) points.push_back(c);
  }
  return points;
}

double widest_baseline(const DenseView& key,
                       const std::vector<const DenseView*>& neighbours) {
  double widest = 0;
  for (const DenseView* n : neighbours) {
    widest = std::max(widest, (n->centre() - key.centre()).norm());
  }
  return widest;
}

struct Plane {
  Eigen::Vector3d normal;
  double offset = 0;  // normal . X = offset
  std::vector<int> inliers;
};

// The plane through the most points (within `tolerance`), by RANSAC with a
// fixed seed so that the sweep stays deterministic.
Plane dominant_plane(const std::vector<Eigen::Vector3d>& points,
                     double tolerance) {
  Plane best;
  if (points.size() < 3) return best;
  std::mt19937 rng(7);
  std::uniform_int_distribution<size_t> pick(0, points.size() - 1);
  for (int iteration = 0; iteration < 300; ++iteration) {
    const Eigen::Vector3d& a = points[pick(rng)];
    const Eigen::Vector3d& b = points[pick(rng)];
    const Eigen::Vector3d& c = points[pick(rng)];
    Eigen::Vector3d normal = (b - a).cross(c - a);
    if (normal.norm() < 1e-12) continue;
    normal.normalize();
    const double offset = normal.dot(a);
    std::vector<int> inliers;
    for (size_t i = 0; i < points.size(); ++i) {
      if (std::abs(normal.dot(points[i]) - offset) <= tolerance)
        inliers.push_back(static_cast<int>(i));
    }
    if (inliers.size() > best.inliers.size()) {
      best = {normal, offset, std::move(inliers)};
    }
  }
  return best;
}

// The planes spaced one plane_step_px apart in the neighbour with the widest
// baseline: the disparity between the nearest and farthest plane, in pixels.
// A pixel's depth on the plane n . X = d is d / (n . K^-1 (x, y, 1)), so
// the disparity between two planes scales with that dot; the largest over
// the picture (at a corner: it is linear in x and y) bounds the step. It is
// 1 for fronto-parallel planes and far below 1 for the ground, whose rays
// meet it at a grazing angle.
int plane_count(const DenseView& key, const Eigen::Vector3d& normal,
                double baseline, double d_near, double d_far,
                const PlaneSweepOptions& options) {
  const Eigen::Vector3d n = key.K.inverse().transpose() * normal;
  const double w = key.bgr.cols, h = key.bgr.rows;
  double ray_dot = 0;
  for (const Eigen::Vector3d corner :
       {Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(w, 0, 1),
        Eigen::Vector3d(0, h, 1), Eigen::Vector3d(w, h, 1)})
    ray_dot = std::max(ray_dot, n.dot(corner));
  const double focal_px = std::max(key.K(0, 0), key.K(1, 1));
  const double disparity =
      focal_px * baseline * ray_dot * (1 / d_near - 1 / d_far);
  const int planes =
      static_cast<int>(std::ceil(disparity / options.plane_step_px));
  return std::clamp(planes, options.min_planes, options.max_planes);
}

std::optional<SweepDirection> direction_for(
    const DenseView& key, const Eigen::Vector3d& normal,
    const std::vector<Eigen::Vector3d>& points, double baseline,
    const PlaneSweepOptions& options) {
  std::vector<double> offsets;
  for (const Eigen::Vector3d& X : points) offsets.push_back(normal.dot(X));
  const double lo = percentile(offsets, 0.02);
  const double hi = percentile(offsets, 0.98);
  SweepDirection direction;
  direction.normal = normal;
  direction.d_near = lo * (1 - options.depth_margin);
  direction.d_far = hi * (1 + options.depth_margin);
  if (!(direction.d_near > 0) || !(direction.d_far > direction.d_near))
    return std::nullopt;
  direction.planes = plane_count(key, direction.normal, baseline,
                                 direction.d_near, direction.d_far, options);
  return direction;
}

// Planes within this angle count as parallel.
constexpr double kParallelDeg = 15;

// Up to `count` dominant plane orientations (normal, and the points on
// planes with that normal), oriented so that the points lie in front
// (positive offsets); nearly fronto-parallel ones are left to the
// fronto-parallel sweep.
std::vector<std::pair<Eigen::Vector3d, std::vector<Eigen::Vector3d>>>
scene_planes(std::vector<Eigen::Vector3d> points, int count) {
  std::vector<std::pair<Eigen::Vector3d, std::vector<Eigen::Vector3d>>> planes;
  std::vector<double> depths;
  for (const auto& X : points) depths.push_back(X.z());
  const double tolerance = 0.02 * percentile(depths, 0.5);
  const size_t min_inliers = std::max<size_t>(30, points.size() / 8);
  for (int found = 0; found < count && points.size() >= min_inliers;) {
    Plane plane = dominant_plane(points, tolerance);
    if (plane.inliers.size() < min_inliers) break;
    Eigen::Vector3d normal = plane.normal;
    if (plane.offset < 0) normal = -normal;
    std::vector<Eigen::Vector3d> on_plane, rest;
    size_t next = 0;
    for (size_t i = 0; i < points.size(); ++i) {
      if (next < plane.inliers.size() &&
          plane.inliers[next] == static_cast<int>(i)) {
        ++next;
        on_plane.push_back(points[i]);
      } else {
        rest.push_back(points[i]);
      }
    }
    points = std::move(rest);
    const double facing_deg =
        std::acos(std::clamp(std::abs(normal.z()), 0.0, 1.0)) * 180 / M_PI;
    if (facing_deg <= kParallelDeg) continue;
    // A plane parallel to one found already (a second facade along the
    // street, a step) gets no sweep of its own: sweeping the gap between
    // the two would cost more than it gains, and the fronto-parallel sweep
    // still covers it.
    const bool parallel =
        std::any_of(planes.begin(), planes.end(), [&](const auto& p) {
          return std::acos(std::clamp(p.first.dot(normal), -1.0, 1.0)) * 180 /
                     M_PI <=
                 kParallelDeg;
        });
    if (parallel) continue;
    planes.emplace_back(normal, std::move(on_plane));
    ++found;
  }
  return planes;
}

bool parallel_to_any(const std::vector<SweepDirection>& directions,
                     const Eigen::Vector3d& normal) {
  return std::any_of(directions.begin(), directions.end(), [&](const auto& d) {
    return std::acos(std::clamp(std::abs(d.normal.dot(normal)), 0.0, 1.0)) *
               180 / M_PI <=
           kParallelDeg;
  });
}

// Planes parallel to the ground, below the camera. The sparse points below
// the camera bound the range; the ground lies at the bottom of the scene,
// so the farthest of them is about its offset, and the nearest plane is at
// least a quarter of that (a street rising ahead): nearer offsets would
// only be the bottoms of facades, and planes spaced in 1/d would crowd
// there.
std::optional<SweepDirection> ground_direction(
    const DenseView& key, const std::vector<Eigen::Vector3d>& points,
    double baseline, const PlaneSweepOptions& options) {
  const Eigen::Vector3d down = -(key.R * key.up).normalized();
  std::vector<double> below;
  for (const Eigen::Vector3d& X : points) {
    const double offset = down.dot(X);
    if (offset > 0) below.push_back(offset);
  }
  if (static_cast<int>(below.size()) < kMinSparsePoints) return std::nullopt;
  SweepDirection direction;
  direction.normal = down;
  direction.ground = true;
  direction.d_far = percentile(below, 0.98) * (1 + options.depth_margin);
  direction.d_near = std::max(percentile(below, 0.02), direction.d_far / 4) *
                     (1 - options.depth_margin);
  direction.planes = plane_count(key, direction.normal, baseline,
                                 direction.d_near, direction.d_far, options);
  return direction;
}

}  // namespace

std::vector<SweepDirection> sweep_directions(
    const DenseView& key, const std::vector<const DenseView*>& neighbours,
    const PlaneSweepOptions& options) {
  const std::vector<Eigen::Vector3d> points = in_key_frame(key);
  std::vector<SweepDirection> directions;
  const double baseline = widest_baseline(key, neighbours);
  if (static_cast<int>(points.size()) < kMinSparsePoints || baseline <= 0)
    return directions;
  if (auto fronto = direction_for(key, Eigen::Vector3d::UnitZ(), points,
                                  baseline, options)) {
    directions.push_back(*fronto);
  } else {
    return directions;
  }
  // Planes parallel to a dominant scene plane, around that plane: its own
  // points bound the range.
  for (const auto& [normal, on_plane] :
       scene_planes(points, options.max_scene_directions)) {
    if (auto d = direction_for(key, normal, on_plane, baseline, options))
      directions.push_back(*d);
  }
  if (options.ground_direction && key.up.norm() > 0.5 &&
      !parallel_to_any(directions, key.R * key.up)) {
    if (auto d = ground_direction(key, points, baseline, options))
      directions.push_back(*d);
  }
  return directions;
}

}  // namespace arscout::engine
