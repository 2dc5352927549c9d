// The CPU plane sweep. Work is split into horizontal strips of the key view
// (one task each); a strip sweeps every plane on its own rows plus a margin
// of half a window, so strips never share state and the result does not
// depend on the thread count.
#include <algorithm>
#include <cmath>
#include <limits>

#include <opencv2/imgproc.hpp>

#include <Eigen/Dense>

#include "arscout/engine/dense.h"
#include "dense/plane_sweep_cuda.h"

namespace arscout::engine {
namespace {

constexpr float kNoScore = -2;  // below any ZNCC

cv::Mat gray_float(const cv::Mat& bgr) {
  cv::Mat gray, result;
  cv::cvtColor(bgr, gray, cv::COLOR_BGR2GRAY);
  gray.convertTo(result, CV_32F);
  return result;
}

cv::Mat box(const cv::Mat& image, int window) {
  cv::Mat result;
  cv::boxFilter(image, result, CV_32F, cv::Size(window, window),
                cv::Point(-1, -1), true, cv::BORDER_REFLECT);
  return result;
}

// The homography taking key pixels to neighbour pixels for the plane
// n . X = d (key camera frame): K_n (R_rel + t_rel n^T / d) K_k^-1.
Eigen::Matrix3d plane_homography(const DenseView& key,
                                 const DenseView& neighbour,
                                 const Eigen::Vector3d& normal, double d) {
  const Eigen::Matrix3d R_rel = neighbour.R * key.R.transpose();
  const Eigen::Vector3d t_rel = neighbour.t - R_rel * key.t;
  return neighbour.K * (R_rel + t_rel * normal.transpose() / d) *
         key.K.inverse();
}

// Per-pixel state of the winner-takes-all search within one strip.
struct Winner {
  cv::Mat score, second, before, after, depth;  // CV_32F
  cv::Mat direction, plane;                     // CV_32S
  explicit Winner(cv::Size size)
      : score(size, CV_32F, cv::Scalar(kNoScore)),
        second(size, CV_32F, cv::Scalar(kNoScore)),
        before(size, CV_32F, cv::Scalar(kNoScore)),
        after(size, CV_32F, cv::Scalar(kNoScore)),
        depth(size, CV_32F, cv::Scalar(0)),
        direction(size, CV_32S, cv::Scalar(-1)),
        plane(size, CV_32S, cv::Scalar(-1)) {}
};

struct KeyStatistics {
  cv::Mat gray, mean, inverse_std;  // inverse_std 0: too little texture
};

KeyStatistics key_statistics(const cv::Mat& gray, int window,
                             double min_texture) {
  KeyStatistics stats;
  stats.gray = gray;
  stats.mean = box(gray, window);
  const cv::Mat mean_sq = box(gray.mul(gray), window);
  stats.inverse_std.create(gray.size(), CV_32F);
  const float min_var = static_cast<float>(min_texture * min_texture);
  for (int y = 0; y < gray.rows; ++y) {
    const float* m = stats.mean.ptr<float>(y);
    const float* m2 = mean_sq.ptr<float>(y);
    float* inv = stats.inverse_std.ptr<float>(y);
    for (int x = 0; x < gray.cols; ++x) {
      const float var = m2[x] - m[x] * m[x];
      inv[x] = var >= min_var && var > 0 ? 1.0f / std::sqrt(var) : 0.0f;
    }
  }
  return stats;
}

// One strip: rows [rows.start, rows.end) of the key view, computed on
// [padded.start, padded.end).
class StripSweep {
 public:
  StripSweep(const DenseView& key, const std::vector<const DenseView*>& views,
             const std::vector<cv::Mat>& grays, const KeyStatistics& stats,
             const PlaneSweepOptions& options, cv::Range rows, cv::Range padded)
      : key_(key),
        views_(views),
        grays_(grays),
        options_(options),
        rows_(rows),
        padded_(padded),
        size_(key.bgr.cols, padded.size()),
        key_gray_(stats.gray.rowRange(padded)),
        key_mean_(stats.mean.rowRange(padded)),
        key_inverse_std_(stats.inverse_std.rowRange(padded)),
        winner_(size_),
        previous_(size_, CV_32F),
        aggregated_(size_, CV_32F),
        ray_dot_(size_, CV_32F) {}

  void run(const std::vector<SweepDirection>& directions) {
    for (size_t f = 0; f < directions.size(); ++f) {
      prepare_direction(directions[f]);
      for (int i = 0; i < directions[f].planes; ++i) {
        score_plane(directions[f], i);
        update_winner(directions[f], static_cast<int>(f), i);
        std::swap(previous_, aggregated_);
      }
    }
  }

  // Sub-plane refinement and rejection, written into the output rows.
  void finish(const std::vector<SweepDirection>& directions,
              DepthMap* out) const;

 private:
  static double inverse_offset(const SweepDirection& d, double plane) {
    const double step =
        d.planes > 1 ? (1 / d.d_far - 1 / d.d_near) / (d.planes - 1) : 0;
    return 1 / d.d_near + plane * step;
  }

  void prepare_direction(const SweepDirection& direction) {
    const Eigen::Matrix3d K_inv = key_.K.inverse();
    const Eigen::Vector3d n = K_inv.transpose() * direction.normal;
    for (int y = 0; y < size_.height; ++y) {
      float* row = ray_dot_.ptr<float>(y);
      const double py = y + padded_.start;
      for (int x = 0; x < size_.width; ++x) {
        row[x] = static_cast<float>(n.x() * x + n.y() * py + n.z());
      }
    }
    previous_.setTo(kNoScore);
  }

  void score_plane(const SweepDirection& direction, int plane) {
    aggregated_.setTo(kNoScore);
    const double d = 1 / inverse_offset(direction, plane);
    for (size_t j = 0; j < views_.size(); ++j) {
      Eigen::Matrix3d H =
          plane_homography(key_, *views_[j], direction.normal, d);
      // Strip rows start at padded_.start: shift before mapping.
      Eigen::Matrix3d shift = Eigen::Matrix3d::Identity();
      shift(1, 2) = padded_.start;
      H = H * shift;
      score_neighbour(H, grays_[j], j == 0);
    }
    if (views_.size() > 1) combine_neighbours();
  }

  void score_neighbour(const Eigen::Matrix3d& H, const cv::Mat& gray,
                       bool first);

  // The mean over the neighbours that see the pixel, unless the best one
  // alone, less a penalty, scores higher: a surface hidden from one
  // neighbour still wins through the other.
  void combine_neighbours() {
    const float penalty = static_cast<float>(options_.occlusion_penalty);
    for (int y = 0; y < size_.height; ++y) {
      float* out = aggregated_.ptr<float>(y);
      const float* sum = sum_.ptr<float>(y);
      const float* count = count_.ptr<float>(y);
      for (int x = 0; x < size_.width; ++x) {
        if (count[x] > 0)
          out[x] = std::max(sum[x] / count[x], out[x] - penalty);
      }
    }
  }
  void update_winner(const SweepDirection& direction, int f, int plane);

  const DenseView& key_;
  const std::vector<const DenseView*>& views_;
  const std::vector<cv::Mat>& grays_;
  const PlaneSweepOptions& options_;
  cv::Range rows_, padded_;
  cv::Size size_;
  cv::Mat key_gray_, key_mean_, key_inverse_std_;
  Winner winner_;
  cv::Mat previous_, aggregated_, ray_dot_;
  cv::Mat warped_, product_, sum_, count_;
};

void StripSweep::score_neighbour(const Eigen::Matrix3d& H, const cv::Mat& gray,
                                 bool first) {
  if (first) {
    sum_ = cv::Mat::zeros(size_, CV_32F);
    count_ = cv::Mat::zeros(size_, CV_32F);
  }
  cv::Mat H_cv(3, 3, CV_64F);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) H_cv.at<double>(r, c) = H(r, c);
  cv::warpPerspective(gray, warped_, H_cv, size_,
                      cv::INTER_LINEAR | cv::WARP_INVERSE_MAP,
                      cv::BORDER_CONSTANT, cv::Scalar(0));
  const int window = options_.window;
  const cv::Mat mean = box(warped_, window);
  const cv::Mat mean_sq = box(warped_.mul(warped_), window);
  cv::multiply(warped_, key_gray_, product_);
  const cv::Mat mean_product = box(product_, window);
  // A window reaching outside the neighbour is not scored.
  const double margin = window / 2 + 1;
  const double max_x = gray.cols - 1 - margin, max_y = gray.rows - 1 - margin;
  for (int y = 0; y < size_.height; ++y) {
    const float* mb = mean.ptr<float>(y);
    const float* mbb = mean_sq.ptr<float>(y);
    const float* mab = mean_product.ptr<float>(y);
    const float* ma = key_mean_.ptr<float>(y);
    const float* inv_a = key_inverse_std_.ptr<float>(y);
    float* out = aggregated_.ptr<float>(y);
    for (int x = 0; x < size_.width; ++x) {
      if (inv_a[x] == 0) continue;
      const double w = H(2, 0) * x + H(2, 1) * y + H(2, 2);
      if (w <= 0) continue;
      const double u = (H(0, 0) * x + H(0, 1) * y + H(0, 2)) / w;
      const double v = (H(1, 0) * x + H(1, 1) * y + H(1, 2)) / w;
      if (u < margin || v < margin || u > max_x || v > max_y) continue;
      const float var_b = mbb[x] - mb[x] * mb[x];
      if (var_b <= 1e-3f) continue;
      const float zncc = (mab[x] - ma[x] * mb[x]) * inv_a[x] / std::sqrt(var_b);
      out[x] = std::max(out[x], zncc);
      sum_.ptr<float>(y)[x] += zncc;
      count_.ptr<float>(y)[x] += 1;
    }
  }
}

void StripSweep::update_winner(const SweepDirection& direction, int f,
                               int plane) {
  const double inverse = inverse_offset(direction, plane);
  const double step = std::abs(inverse_offset(direction, plane + 1) - inverse);
  // Depths closer than three plane steps belong to the winner's basin; the
  // runner-up must come from elsewhere for the margin to mean anything.
  const float basin = static_cast<float>(std::max(0.005, 3 * step / inverse));
  const float d = static_cast<float>(1 / inverse);
  for (int y = 0; y < size_.height; ++y) {
    const float* score = aggregated_.ptr<float>(y);
    const float* previous = previous_.ptr<float>(y);
    const float* ray = ray_dot_.ptr<float>(y);
    float* best = winner_.score.ptr<float>(y);
    float* second = winner_.second.ptr<float>(y);
    float* before = winner_.before.ptr<float>(y);
    float* after = winner_.after.ptr<float>(y);
    float* depth = winner_.depth.ptr<float>(y);
    int* dir = winner_.direction.ptr<int>(y);
    int* index = winner_.plane.ptr<int>(y);
    for (int x = 0; x < size_.width; ++x) {
      if (dir[x] == f && index[x] == plane - 1) after[x] = score[x];
      const float s = score[x];
      if (s <= kNoScore || ray[x] <= 1e-6f) continue;
      const float z = d / ray[x];
      const bool same_basin =
          depth[x] > 0 && std::abs(z - depth[x]) <= basin * depth[x];
      if (s > best[x]) {
        if (!same_basin) second[x] = best[x];
        best[x] = s;
        depth[x] = z;
        dir[x] = f;
        index[x] = plane;
        before[x] = previous[x];
        after[x] = kNoScore;
      } else if (!same_basin && s > second[x]) {
        second[x] = s;
      }
    }
  }
}

void StripSweep::finish(const std::vector<SweepDirection>& directions,
                        DepthMap* out) const {
  const int offset = rows_.start - padded_.start;
  for (int y = 0; y < rows_.size(); ++y) {
    const int sy = y + offset;
    float* depth = out->depth.ptr<float>(rows_.start + y);
    float* score = out->score.ptr<float>(rows_.start + y);
    float* margin = out->margin.ptr<float>(rows_.start + y);
    for (int x = 0; x < size_.width; ++x) {
      const int f = winner_.direction.at<int>(sy, x);
      if (f < 0) continue;
      const SweepDirection& dir = directions[f];
      const int plane = winner_.plane.at<int>(sy, x);
      const float best = winner_.score.at<float>(sy, x);
      const float before = winner_.before.at<float>(sy, x);
      const float after = winner_.after.at<float>(sy, x);
      score[x] = best;
      margin[x] = best - std::max(winner_.second.at<float>(sy, x), -1.0f);
      // A winner on the first or last plane may lie beyond the range.
      if (plane == 0 || plane == dir.planes - 1 || before <= kNoScore ||
          after <= kNoScore || best < options_.min_score ||
          margin[x] < options_.min_margin) {
        continue;
      }
      const double curvature = before - 2.0 * best + after;
      const double shift =
          curvature < 0
              ? std::clamp(0.5 * (before - after) / curvature, -0.5, 0.5)
              : 0.0;
      const double d = 1 / inverse_offset(dir, plane + shift);
      const Eigen::Vector3d n = key_.K.inverse().transpose() * dir.normal;
      const double ray_dot = n.x() * x + n.y() * (rows_.start + y) + n.z();
      depth[x] = static_cast<float>(d / ray_dot);
    }
  }
}

DepthMap empty_depth_map(const DenseView& key) {
  DepthMap map;
  map.id = key.id;
  map.K = key.K;
  map.R = key.R;
  map.t = key.t;
  map.depth = cv::Mat::zeros(key.bgr.size(), CV_32F);
  map.score = cv::Mat::zeros(key.bgr.size(), CV_32F);
  map.margin = cv::Mat::zeros(key.bgr.size(), CV_32F);
  return map;
}

void check_views(const DenseView& key,
                 const std::vector<const DenseView*>& neighbours,
                 const PlaneSweepOptions& options) {
  if (key.bgr.empty() || key.bgr.type() != CV_8UC3)
    throw std::invalid_argument("sweep_planes: key image must be 8-bit BGR");
  if (options.window < 3 || options.window % 2 == 0)
    throw std::invalid_argument("sweep_planes: window must be odd and >= 3");
  for (const DenseView* n : neighbours) {
    if (n->bgr.size() != key.bgr.size() || n->bgr.type() != CV_8UC3)
      throw std::invalid_argument(
          "sweep_planes: neighbour images must match the key's size");
  }
}

}  // namespace

double DepthMap::coverage() const {
  if (depth.empty()) return 0;
  return static_cast<double>(cv::countNonZero(depth > 0)) / depth.total();
}

Eigen::Vector3d DepthMap::unproject(double x, double y, double z) const {
  const Eigen::Vector3d ray = K.inverse() * Eigen::Vector3d(x, y, 1);
  return R.transpose() * (z * ray - t);
}

DepthMap sweep_planes(const DenseView& key,
                      const std::vector<const DenseView*>& neighbours,
                      const PlaneSweepOptions& options) {
  check_views(key, neighbours, options);
  DepthMap map = empty_depth_map(key);
  const std::vector<SweepDirection> directions =
      sweep_directions(key, neighbours, options);
  if (directions.empty() || neighbours.empty()) return map;
  if (options.use_cuda && cuda::available()) {
    cuda::sweep_planes(key, neighbours, directions, options, &map);
    return map;
  }
  std::vector<cv::Mat> grays;
  for (const DenseView* n : neighbours) grays.push_back(gray_float(n->bgr));
  const KeyStatistics stats =
      key_statistics(gray_float(key.bgr), options.window, options.min_texture);
  const int rows = key.bgr.rows;
  const int strips =
      std::clamp(rows / 32, 1, 4 * std::max(1, cv::getNumThreads()));
  const int pad = options.window / 2 + 1;
  cv::parallel_for_(cv::Range(0, strips), [&](const cv::Range& range) {
    for (int s = range.start; s < range.end; ++s) {
      const cv::Range own(rows * s / strips, rows * (s + 1) / strips);
      const cv::Range padded(std::max(0, own.start - pad),
                             std::min(rows, own.end + pad));
      StripSweep strip(key, neighbours, grays, stats, options, own, padded);
      strip.run(directions);
      strip.finish(directions, &map);
    }
  });
  return map;
}

}  // namespace arscout::engine
