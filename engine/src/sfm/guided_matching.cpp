#include "sfm/guided_matching.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include <Eigen/Geometry>

namespace arscout::engine {
namespace {

// The ratio test's competitors: every keypoint within this many pixels of
// the line, a wider band than the candidates'. Among the few candidates
// alone a wrong corner often stands unopposed.
constexpr double kCompetitorBandPx = 8;
// Grid cells, in the second image's working pixels: about a dozen
// keypoints each at 4500 corners in a 1600 x 1200 image.
constexpr double kCellPx = 32;

// Keypoints of one image bucketed by their normalized coordinates, so that
// the candidates along a line are found without visiting all of them.
class KeypointGrid {
 public:
  KeypointGrid(const std::vector<Eigen::Vector2d>& points, double cell)
      : points_(points), cell_(cell) {
    Eigen::Vector2d lo = Eigen::Vector2d::Constant(0);
    Eigen::Vector2d hi = lo;
    if (!points.empty()) lo = hi = points[0];
    for (const Eigen::Vector2d& p : points) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
    origin_ = lo;
    cols_ = static_cast<int>((hi.x() - lo.x()) / cell) + 1;
    rows_ = static_cast<int>((hi.y() - lo.y()) / cell) + 1;
    cells_.resize(static_cast<size_t>(cols_) * rows_);
    for (size_t i = 0; i < points.size(); ++i)
      cells_[cell_of(points[i])].push_back(static_cast<int>(i));
  }

  // Indices of the points within `distance` of the line l . (x, y, 1) = 0,
  // with (l[0], l[1]) of unit length.
  std::vector<int> near_line(const Eigen::Vector3d& l, double distance) const {
    std::vector<int> found;
    const bool flat = std::abs(l[1]) >= std::abs(l[0]);
    const int lanes = flat ? cols_ : rows_;
    const int across = flat ? rows_ : cols_;
    const double along0 = flat ? origin_.x() : origin_.y();
    const double across0 = flat ? origin_.y() : origin_.x();
    const double a = flat ? l[0] : l[1];  // coefficient of the lane axis
    const double b = flat ? l[1] : l[0];  // of the axis across the lanes
    const double widen = distance / std::abs(b);
    for (int lane = 0; lane < lanes; ++lane) {
      const double u0 = along0 + lane * cell_, u1 = u0 + cell_;
      const double v0 = -(a * u0 + l[2]) / b, v1 = -(a * u1 + l[2]) / b;
      const int first = cell_index(std::min(v0, v1) - widen - across0);
      const int last = cell_index(std::max(v0, v1) + widen - across0);
      for (int k = std::max(first, 0); k <= std::min(last, across - 1); ++k) {
        const size_t cell = flat ? static_cast<size_t>(k) * cols_ + lane
                                 : static_cast<size_t>(lane) * cols_ + k;
        for (int i : cells_[cell]) {
          const Eigen::Vector2d& p = points_[i];
          if (std::abs(l[0] * p.x() + l[1] * p.y() + l[2]) <= distance)
            found.push_back(i);
        }
      }
    }
    return found;
  }

 private:
  int cell_index(double offset) const {
    const double k = std::floor(offset / cell_);
    return static_cast<int>(std::clamp(k, -1.0, 1e6));
  }
  size_t cell_of(const Eigen::Vector2d& p) const {
    const int col = std::min(cell_index(p.x() - origin_.x()), cols_ - 1);
    const int row = std::min(cell_index(p.y() - origin_.y()), rows_ - 1);
    return static_cast<size_t>(row) * cols_ + col;
  }

  const std::vector<Eigen::Vector2d>& points_;
  double cell_;
  Eigen::Vector2d origin_;
  int cols_ = 1, rows_ = 1;
  std::vector<std::vector<int>> cells_;
};

// The essential matrix taking normalized rays of `a` to epipolar lines of
// `b` (x_b' E x_a = 0) from the two world-to-camera poses.
Eigen::Matrix3d essential(const SceneImage& a, const SceneImage& b) {
  const Eigen::Matrix3d R = (b.q * a.q.conjugate()).toRotationMatrix();
  const Eigen::Vector3d t = b.t - R * a.t;
  Eigen::Matrix3d tx;
  tx << 0, -t.z(), t.y(), t.z(), 0, -t.x(), -t.y(), t.x(), 0;
  return tx * R;
}

double descriptor_distance(const cv::Mat& a, int row_a, const cv::Mat& b,
                           int row_b) {
  const float* x = a.ptr<float>(row_a);
  const float* y = b.ptr<float>(row_b);
  float dot = 0;
  for (int c = 0; c < a.cols; ++c) dot += x[c] * y[c];
  return std::sqrt(std::max(0.0, 2.0 - 2.0 * dot));
}

}  // namespace

std::vector<std::pair<int, int>> guided_matches(
    const SceneCamera& camera_a, const SceneImage& a,
    const std::vector<int>& from_a, const SceneCamera& camera_b,
    const SceneImage& b, const std::vector<int>& from_b,
    const GuidedMatchOptions& options) {
  if (from_a.empty() || from_b.empty()) return {};
  std::vector<Eigen::Vector2d> rays_b;
  rays_b.reserve(from_b.size());
  for (int k : from_b) rays_b.push_back(normalize(camera_b, b.keypoints[k]));
  const double focal = camera_b.params[0];
  const KeypointGrid grid(rays_b, kCellPx / focal);
  const double threshold = options.max_epipolar_px / focal;
  const double band =
      std::max(kCompetitorBandPx, options.max_epipolar_px) / focal;
  const Eigen::Matrix3d E = essential(a, b);
  // The best keypoint of `a` for each chosen one of `b`: (distance, match).
  std::map<int, std::pair<double, size_t>> taken;
  std::vector<std::pair<int, int>> matches;
  for (int ka : from_a) {
    Eigen::Vector3d line =
        E * normalize(camera_a, a.keypoints[ka]).homogeneous();
    const double norm = line.head<2>().norm();
    if (!(norm > 0)) continue;
    line /= norm;
    double best = std::numeric_limits<double>::infinity();
    double second = best;
    int best_b = -1;
    for (int i : grid.near_line(line, band)) {
      const double d =
          descriptor_distance(a.descriptors, ka, b.descriptors, from_b[i]);
      const bool candidate =
          std::abs(line.dot(rays_b[i].homogeneous())) <= threshold;
      if (candidate && d < best) {
        second = std::min(second, best);
        best = d;
        best_b = from_b[i];
      } else {
        second = std::min(second, d);
      }
    }
    if (best_b < 0 || !std::isfinite(second) ||
        !(best < options.ratio * second))
      continue;
    const auto held = taken.find(best_b);
    if (held != taken.end() && held->second.first <= best) continue;
    if (held != taken.end()) matches[held->second.second].second = -1;
    taken[best_b] = {best, matches.size()};
    matches.push_back({ka, best_b});
  }
  std::erase_if(matches, [](const auto& m) { return m.second < 0; });
  return matches;
}

}  // namespace arscout::engine
