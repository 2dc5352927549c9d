#include "dense_eval.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <stdexcept>
#include <unordered_map>

#include <Eigen/Dense>

#include "progress_log.h"

namespace arscout::eval {

namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

double distance_to_segment(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                           const Eigen::Vector3d& p) {
  const Eigen::Vector3d ab = b - a;
  const double length2 = ab.squaredNorm();
  const double s =
      length2 > 0 ? std::clamp((p - a).dot(ab) / length2, 0.0, 1.0) : 0.0;
  return (a + s * ab - p).norm();
}

double distance_to_border(const Parallelogram& q, const Eigen::Vector3d& p) {
  const Eigen::Vector3d c0 = q.corner, c1 = q.corner + q.edge_u,
                        c2 = c1 + q.edge_v, c3 = q.corner + q.edge_v;
  return std::min(
      {distance_to_segment(c0, c1, p), distance_to_segment(c1, c2, p),
       distance_to_segment(c2, c3, p), distance_to_segment(c3, c0, p)});
}

double distance_to_box(const Eigen::Vector3d& low, const Eigen::Vector3d& high,
                       const Eigen::Vector3d& p) {
  const Eigen::Vector3d outside =
      (low - p).cwiseMax(p - high).cwiseMax(Eigen::Vector3d::Zero());
  return outside.norm();
}

}  // namespace

double distance_to(const Parallelogram& q, const Eigen::Vector3d& p) {
  const Eigen::Vector3d normal = q.edge_u.cross(q.edge_v);
  const double area = normal.norm();
  if (area <= 1e-9 * q.edge_u.norm() * q.edge_v.norm())
    return distance_to_border(q, p);
  // p - corner = s u + t v + w n: the Gram system gives (s, t).
  const Eigen::Vector3d d = p - q.corner;
  const double uu = q.edge_u.squaredNorm(), vv = q.edge_v.squaredNorm();
  const double uv = q.edge_u.dot(q.edge_v);
  const double du = d.dot(q.edge_u), dv = d.dot(q.edge_v);
  const double det = uu * vv - uv * uv;
  const double s = (du * vv - dv * uv) / det, t = (dv * uu - du * uv) / det;
  if (s >= 0 && s <= 1 && t >= 0 && t <= 1)
    return std::abs(d.dot(normal)) / area;
  return distance_to_border(q, p);
}

SurfaceDistance::SurfaceDistance(std::vector<Parallelogram> surfaces)
    : surfaces_(std::move(surfaces)) {
  for (const Parallelogram& q : surfaces_) {
    Eigen::Vector3d low = q.corner, high = q.corner;
    for (const Eigen::Vector3d& c :
         {Eigen::Vector3d(q.corner + q.edge_u),
          Eigen::Vector3d(q.corner + q.edge_v),
          Eigen::Vector3d(q.corner + q.edge_u + q.edge_v)}) {
      low = low.cwiseMin(c);
      high = high.cwiseMax(c);
    }
    box_min_.push_back(low);
    box_max_.push_back(high);
  }
}

double SurfaceDistance::operator()(const Eigen::Vector3d& p) const {
  double best = kInfinity;
  for (std::size_t i = 0; i < surfaces_.size(); ++i) {
    if (distance_to_box(box_min_[i], box_max_[i], p) >= best) continue;
    best = std::min(best, distance_to(surfaces_[i], p));
  }
  return best;
}

AccuracyFigures measure_accuracy(const std::vector<Eigen::Vector3d>& points,
                                 const SurfaceDistance& truth,
                                 double tolerance_m) {
  AccuracyFigures figures;
  if (points.empty()) return figures;
  std::vector<double> distances;
  distances.reserve(points.size());
  int within = 0;
  for (const Eigen::Vector3d& p : points) {
    distances.push_back(truth(p));
    within += distances.back() <= tolerance_m;
  }
  figures.points = static_cast<int>(points.size());
  figures.within_share = static_cast<double>(within) / figures.points;
  figures.median_m = percentile(distances, 0.5);
  figures.p90_m = percentile(std::move(distances), 0.9);
  return figures;
}

// --- completeness ------------------------------------------------------------

namespace {

// The cloud's points bucketed on a grid of `cell` edges, for "is there a
// point within `cell` of x".
class PointGrid {
 public:
  PointGrid(const std::vector<Eigen::Vector3d>& points, double cell)
      : points_(points), cell_(cell) {
    for (std::size_t i = 0; i < points.size(); ++i)
      buckets_[key(cell_of(points[i]))].push_back(i);
  }

  bool has_point_within(const Eigen::Vector3d& x) const {
    const Eigen::Vector3i c = cell_of(x);
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz) {
          const auto it = buckets_.find(key(c + Eigen::Vector3i(dx, dy, dz)));
          if (it == buckets_.end()) continue;
          for (std::size_t i : it->second)
            if ((points_[i] - x).squaredNorm() <= cell_ * cell_) return true;
        }
    return false;
  }

 private:
  Eigen::Vector3i cell_of(const Eigen::Vector3d& x) const {
    return (x / cell_).array().floor().cast<int>();
  }
  static int64_t key(const Eigen::Vector3i& c) {
    const auto part = [](int v) {
      return static_cast<int64_t>(static_cast<uint32_t>(v) & 0x1fffff);
    };
    return part(c.x()) | part(c.y()) << 21 | part(c.z()) << 42;
  }

  const std::vector<Eigen::Vector3d>& points_;
  double cell_;
  std::unordered_map<int64_t, std::vector<std::size_t>> buckets_;
};

bool view_sees(const DepthView& view, const Eigen::Vector3d& x,
               const Eigen::Vector3d& normal,
               const CompletenessOptions& options) {
  const Eigen::Vector3d camera = view.R * x + view.t;
  if (camera.z() <= 0) return false;
  const Eigen::Vector3d pixel = view.K * (camera / camera.z());
  const long col = std::lround(pixel.x()), row = std::lround(pixel.y());
  if (col < 0 || row < 0 || col >= view.width || row >= view.height)
    return false;
  const double surface = view.depth[row * view.width + col];
  if (surface <= 0 || camera.z() > surface + std::max(0.01 * surface, 0.02))
    return false;
  if (options.footprint_focal_px <= 0) return true;
  const double range = camera.norm();
  const double cosine =
      std::abs((view.R.transpose() * camera).dot(normal)) / range;
  return range <= options.max_footprint_m * options.footprint_focal_px * cosine;
}

// The views that could resolve some part of `surface`: none farther than
// the footprint limit allows.
std::vector<const DepthView*> candidate_views(
    const Parallelogram& surface, const std::vector<DepthView>& views,
    const CompletenessOptions& options) {
  std::vector<const DepthView*> candidates;
  const double reach =
      options.footprint_focal_px > 0
          ? options.max_footprint_m * options.footprint_focal_px
          : kInfinity;
  for (const DepthView& view : views)
    if (distance_to(surface, -view.R.transpose() * view.t) <= reach)
      candidates.push_back(&view);
  return candidates;
}

void sample_surface(const Parallelogram& surface,
                    const std::vector<DepthView>& views, const PointGrid& grid,
                    const CompletenessOptions& options,
                    CompletenessFigures& figures) {
  const auto candidates = candidate_views(surface, views, options);
  const Eigen::Vector3d normal =
      surface.edge_u.cross(surface.edge_v).normalized();
  const int nu = std::max(1, static_cast<int>(std::ceil(surface.edge_u.norm() /
                                                        options.spacing_m)));
  const int nv = std::max(1, static_cast<int>(std::ceil(surface.edge_v.norm() /
                                                        options.spacing_m)));
  figures.samples += static_cast<int64_t>(nu) * nv;
  if (static_cast<int>(candidates.size()) < options.min_views) return;
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      const Eigen::Vector3d x = surface.corner +
                                (i + 0.5) / nu * surface.edge_u +
                                (j + 0.5) / nv * surface.edge_v;
      int seeing = 0;
      for (const DepthView* view : candidates)
        seeing += view_sees(*view, x, normal, options);
      if (seeing < options.min_views) continue;
      const bool covered = grid.has_point_within(x);
      const int bucket = std::min(seeing, kMostViewsCounted);
      ++figures.seen;
      ++figures.seen_by_views[bucket];
      figures.covered += covered;
      figures.covered_by_views[bucket] += covered;
    }
}

}  // namespace

CompletenessFigures measure_completeness(
    const std::vector<Parallelogram>& surfaces,
    const std::vector<DepthView>& views,
    const std::vector<Eigen::Vector3d>& points,
    const CompletenessOptions& options) {
  if (options.spacing_m <= 0 || options.tolerance_m <= 0)
    throw std::invalid_argument(
        "completeness: spacing and tolerance must be > 0");
  for (const DepthView& view : views)
    if (view.width <= 0 || view.height <= 0 ||
        view.depth.size() != static_cast<std::size_t>(view.width) * view.height)
      throw std::invalid_argument(
          "completeness: a depth image of the wrong size");
  const PointGrid grid(points, options.tolerance_m);
  CompletenessFigures figures;
  for (const Parallelogram& surface : surfaces)
    sample_surface(surface, views, grid, options, figures);
  figures.share = figures.seen > 0
                      ? static_cast<double>(figures.covered) / figures.seen
                      : 0.0;
  return figures;
}

// --- plausibility ------------------------------------------------------------

bool sky_coloured(uint8_t r, uint8_t g, uint8_t b) {
  const int high = std::max({r, g, b}), low = std::min({r, g, b});
  if (high == low || high < 0.55 * 255 || high - low < 0.12 * high)
    return false;
  const double span = high - low;
  double hue = 0;
  if (high == b)
    hue = 240 + 60 * (r - g) / span;
  else if (high == g)
    hue = 120 + 60 * (b - r) / span;
  else
    hue = std::fmod(360 + 60 * (g - b) / span, 360.0);
  return hue >= 190 && hue <= 250;
}

namespace {

const Eigen::Vector3d& nearest_horizontally(
    const Eigen::Vector3d& x, const std::vector<Eigen::Vector3d>& cameras) {
  std::size_t best = 0;
  double best_d2 = kInfinity;
  for (std::size_t i = 0; i < cameras.size(); ++i) {
    const double d2 = (cameras[i] - x).head<2>().squaredNorm();
    if (d2 < best_d2) best_d2 = d2, best = i;
  }
  return cameras[best];
}

}  // namespace

PlausibilityFigures measure_plausibility(
    const std::vector<CloudPoint>& points,
    const std::vector<Eigen::Vector3d>& cameras,
    const PlausibilityOptions& options) {
  PlausibilityFigures f;
  if (points.empty()) return f;
  if (cameras.empty())
    throw std::invalid_argument("plausibility: points but no cameras");
  int far = 0, above = 0, below = 0, sky = 0, any = 0;
  for (const CloudPoint& p : points) {
    const Eigen::Vector3d& camera = nearest_horizontally(p.xyz, cameras);
    const bool is_far =
        (p.xyz - camera).head<2>().norm() > options.max_horizontal_m;
    const bool is_above = p.xyz.z() - camera.z() > options.max_above_m;
    const bool is_below = camera.z() - p.xyz.z() > options.max_below_m;
    const bool is_sky = sky_coloured(p.r, p.g, p.b);
    far += is_far, above += is_above, below += is_below, sky += is_sky;
    any += is_far || is_above || is_below || is_sky;
  }
  f.points = static_cast<int>(points.size());
  const double n = f.points;
  f.far_share = far / n, f.above_share = above / n, f.below_share = below / n;
  f.sky_share = sky / n, f.implausible_share = any / n;
  return f;
}

double ground_cover_m2(const std::vector<CloudPoint>& points,
                       const std::vector<Eigen::Vector3d>& cameras,
                       double cell_m, double band_m) {
  if (points.empty() || cameras.empty()) return 0;
  constexpr double kLowest = 0.8, kHighest = 4, kBin = 0.1;
  std::vector<double> drops;
  drops.reserve(points.size());
  std::vector<int> bins(static_cast<int>((kHighest - kLowest) / kBin), 0);
  for (const CloudPoint& p : points) {
    const double drop = nearest_horizontally(p.xyz, cameras).z() - p.xyz.z();
    drops.push_back(drop);
    if (drop >= kLowest && drop < kHighest)
      ++bins[static_cast<int>((drop - kLowest) / kBin)];
  }
  const auto mode = std::max_element(bins.begin(), bins.end());
  if (*mode == 0) return 0;
  const double height = kLowest + (mode - bins.begin() + 0.5) * kBin;
  std::set<std::pair<int64_t, int64_t>> cells;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (std::abs(drops[i] - height) > band_m) continue;
    cells.emplace(static_cast<int64_t>(std::floor(points[i].xyz.x() / cell_m)),
                  static_cast<int64_t>(std::floor(points[i].xyz.y() / cell_m)));
  }
  return cells.size() * cell_m * cell_m;
}

}  // namespace arscout::eval
