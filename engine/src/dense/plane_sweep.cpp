// The CPU plane sweep. Work is split into horizontal strips of the key view
// (one task each). A strip warps the neighbours on its own rows plus half a
// window above and below (and half a window beyond the left and right
// edges), taking rows and columns outside the image by reflection as the
// window sums do, so strips share no state and the result does not depend
// on the thread count.
//
// Per plane and neighbour a strip makes two passes over whole rows: a warp
// (the homography, bilinear on cv::warpPerspective's 1/32-pixel grid so
// that the CUDA path can match it) that also stores b^2 and a*b, then
// separable window sums of b, b^2 and a*b and the ZNCC. The row loops are
// in sweep_kernels.cpp.
#include <algorithm>
#include <cmath>
#include <limits>

#include <opencv2/imgproc.hpp>

#include <Eigen/Dense>

#include "arscout/engine/dense.h"
#include "dense/consistency.h"
#include "dense/plane_sweep_cuda.h"
#include "dense/sky_mask.h"
#include "dense/sweep_kernels.h"
#include "dense/sweep_setup.h"

namespace arscout::engine {
namespace {

using sweep_kernels::kGreyCentre;
using sweep_kernels::kGreyPad;
using sweep_kernels::kNoScore;

// Window column sums restart every this many image rows (window_sums).
constexpr int kSumBlock = 16;
constexpr int kMaxWindow = 31;

int round_up(int n) {
  const int k = sweep_kernels::kRowAlignment;
  return (n + k - 1) / k * k;
}

// cv::BORDER_REFLECT: fedcba|abcdefgh|hgfedcb.
int reflect(int p, int n) {
  if (n == 1) return 0;
  while (p < 0 || p >= n) p = p < 0 ? -p - 1 : 2 * n - p - 1;
  return p;
}

using sweep_setup::plane_homography;

// What every strip reads: computed once per sweep.
struct SweepInputs {
  const DenseView& key;
  const std::vector<const DenseView*>& neighbours;
  const PlaneSweepOptions& options;
  cv::Mat key_grey;               // centred
  cv::Mat key_mean, inverse_std;  // window statistics; inverse_std 0:
                                  // too little texture
  std::vector<cv::Mat> grays;     // the neighbours', not centred, with
                                  // a zero border of kGreyPad pixels
};

SweepInputs sweep_inputs(const DenseView& key,
                         const std::vector<const DenseView*>& neighbours,
                         const PlaneSweepOptions& options) {
  SweepInputs in{key, neighbours, options, {}, {}, {}, {}};
  in.key_grey = sweep_setup::grey_levels(key.bgr) - kGreyCentre;
  in.inverse_std = sweep_setup::inverse_window_std(
      in.key_grey, options.window, options.min_texture, &in.key_mean);
  for (const DenseView* n : neighbours) {
    cv::Mat padded;
    cv::copyMakeBorder(sweep_setup::grey_levels(n->bgr), padded, kGreyPad,
                       kGreyPad, kGreyPad, kGreyPad, cv::BORDER_CONSTANT, 0);
    in.grays.push_back(padded);
  }
  return in;
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

// One strip: rows [rows.start, rows.end) of the key view. Its buffers are
// padded on the right to a multiple of the kernels' vector width;
// "extended" buffers also hold `radius` more rows and columns on every side.
class StripSweep {
 public:
  StripSweep(const SweepInputs& in, cv::Range rows);

  void run(const std::vector<SweepDirection>& directions) {
    for (size_t f = 0; f < directions.size(); ++f) {
      // A direction whose planes meet no ray of the strip (the ground's,
      // above the horizon) could not win anywhere in it.
      if (!prepare_direction(directions[f])) continue;
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

  // False when no ray of the strip meets the direction's planes in front.
  bool prepare_direction(const SweepDirection& direction) {
    const Eigen::Vector3d n =
        in_.key.K.inverse().transpose() * direction.normal;
    for (int y = 0; y < size_.height; ++y) {
      float* row = ray_dot_.ptr<float>(y);
      const double py = y + rows_.start;
      for (int x = 0; x < padded_width_; ++x) {
        row[x] = static_cast<float>(n.x() * x + n.y() * py + n.z());
      }
    }
    previous_.setTo(kNoScore);
    double lowest = 0, highest = 0;
    cv::minMaxLoc(ray_dot_, &lowest, &highest);
    return highest > sweep_kernels::kMinRayDot;
  }

  void score_plane(const SweepDirection& direction, int plane) {
    aggregated_.setTo(kNoScore);
    sum_.setTo(0);
    count_.setTo(0);
    const double d = 1 / inverse_offset(direction, plane);
    for (size_t j = 0; j < in_.neighbours.size(); ++j) {
      score_neighbour(
          plane_homography(in_.key, *in_.neighbours[j], direction.normal, d),
          in_.grays[j]);
    }
    if (in_.neighbours.size() > 1) combine_neighbours();
  }

  void score_neighbour(const Eigen::Matrix3d& H, const cv::Mat& grey);
  void window_sums(int y);
  // Ring buffer row of extended row e.
  int slot(int e) const { return e % ring_rows_; }

  // The mean over the neighbours that see the pixel, unless the best one
  // alone, less a penalty, scores higher: a surface hidden from one
  // neighbour still wins through the other.
  void combine_neighbours() {
    const float penalty = static_cast<float>(in_.options.occlusion_penalty);
    for (int y = 0; y < size_.height; ++y) {
      sweep_kernels::combine_row(sum_.ptr<float>(y), count_.ptr<float>(y),
                                 penalty, padded_width_,
                                 aggregated_.ptr<float>(y));
    }
  }
  void update_winner(const SweepDirection& direction, int f, int plane);

  const SweepInputs& in_;
  cv::Range rows_;
  cv::Size size_;  // the strip's key pixels
  int radius_;
  int padded_width_;
  cv::Mat key_mean_, inverse_std_;  // the strip's rows, padded
  std::vector<int> source_rows_;    // extended -> key, reflected
  std::vector<float> source_cols_;  // likewise
  cv::Mat key_extended_;            // centred key grey
  // The warped extended rows, the last ring_rows_ of them: rows are
  // warped just before their window sums need them, so the buffers stay
  // in cache.
  int ring_rows_;
  cv::Mat b_, bb_, ab_, inside_;
  cv::Mat column_sums_;  // 3 rows: b, bb, ab
  cv::Mat window_sums_;  // 3 rows: b, bb, ab
  Winner winner_;
  cv::Mat previous_, aggregated_, sum_, count_, ray_dot_;
};

StripSweep::StripSweep(const SweepInputs& in, cv::Range rows)
    : in_(in),
      rows_(rows),
      size_(in.key.bgr.cols, rows.size()),
      radius_(in.options.window / 2),
      padded_width_(round_up(size_.width)),
      winner_(cv::Size(padded_width_, size_.height)),
      previous_(size_.height, padded_width_, CV_32F),
      aggregated_(size_.height, padded_width_, CV_32F),
      sum_(size_.height, padded_width_, CV_32F),
      count_(size_.height, padded_width_, CV_32F),
      ray_dot_(size_.height, padded_width_, CV_32F) {
  const cv::Size extended(round_up(padded_width_ + 2 * radius_),
                          size_.height + 2 * radius_);
  for (cv::Mat* m : {&key_mean_, &inverse_std_}) {
    *m = cv::Mat::zeros(size_.height, padded_width_, CV_32F);
  }
  in.key_mean.rowRange(rows).copyTo(key_mean_.colRange(0, size_.width));
  in.inverse_std.rowRange(rows).copyTo(inverse_std_.colRange(0, size_.width));
  for (int e = 0; e < extended.height; ++e)
    source_rows_.push_back(reflect(rows.start - radius_ + e, in.key.bgr.rows));
  for (int c = 0; c < extended.width; ++c)
    source_cols_.push_back(
        static_cast<float>(reflect(c - radius_, size_.width)));
  key_extended_.create(extended, CV_32F);
  for (int e = 0; e < extended.height; ++e) {
    const float* source = in.key_grey.ptr<float>(source_rows_[e]);
    float* row = key_extended_.ptr<float>(e);
    for (int c = 0; c < extended.width; ++c)
      row[c] = source[static_cast<int>(source_cols_[c])];
  }
  ring_rows_ = 2 * radius_ + 2;  // a window, and the row leaving it
  for (cv::Mat* m : {&b_, &bb_, &ab_, &inside_})
    m->create(ring_rows_, extended.width, CV_32F);
  column_sums_.create(3, extended.width, CV_32F);
  window_sums_.create(3, padded_width_, CV_32F);
}

// The sums of b, b^2 and a*b over the window centred on each pixel of
// strip row y, into window_sums_ (rows 0, 1, 2).
void StripSweep::window_sums(int y) {
  const int window = 2 * radius_ + 1;
  const cv::Mat* sources[3] = {&b_, &bb_, &ab_};
  // Column sums slide down from row to row, and start afresh at every
  // kSumBlock-th image row; strips start on such rows, so the float
  // rounding is the same whichever strip, and thread, a row falls in.
  const bool fresh = (rows_.start + y) % kSumBlock == 0;
  for (int q = 0; q < 3; ++q) {
    float* column = column_sums_.ptr<float>(q);
    if (fresh) {
      const float* rows[kMaxWindow];
      for (int k = 0; k < window; ++k)
        rows[k] = sources[q]->ptr<float>(slot(y + k));
      sweep_kernels::sum_rows(rows, window, column_sums_.cols, column);
    } else {
      sweep_kernels::slide_rows(
          column, sources[q]->ptr<float>(slot(y + window - 1)),
          sources[q]->ptr<float>(slot(y - 1)), column_sums_.cols);
    }
    sweep_kernels::sum_runs(column, window, padded_width_,
                            window_sums_.ptr<float>(q));
  }
}

// This neighbour's ZNCC through H at every strip pixel, folded into the
// running best (aggregated_), sum and count. Extended rows are warped
// (sweep_kernels::warp_row: b, b^2, a*b, inside) as the window reaches
// them.
void StripSweep::score_neighbour(const Eigen::Matrix3d& H,
                                 const cv::Mat& grey) {
  float h[9];
  for (int k = 0; k < 9; ++k) h[k] = static_cast<float>(H(k / 3, k % 3));
  const sweep_kernels::PaddedGrey padded{
      grey.ptr<float>(), static_cast<int>(grey.step1()),
      grey.cols - 2 * kGreyPad, grey.rows - 2 * kGreyPad};
  const float margin = static_cast<float>(radius_ + 1);
  const float inverse_n =
      1.0f / static_cast<float>((2 * radius_ + 1) * (2 * radius_ + 1));
  int warped = 0;  // extended rows warped so far
  for (int y = 0; y < size_.height; ++y) {
    for (; warped <= y + 2 * radius_; ++warped) {
      const int r = slot(warped);
      sweep_kernels::warp_row(h, static_cast<float>(source_rows_[warped]),
                              source_cols_.data(), b_.cols, padded, margin,
                              key_extended_.ptr<float>(warped),
                              b_.ptr<float>(r), bb_.ptr<float>(r),
                              ab_.ptr<float>(r), inside_.ptr<float>(r));
    }
    window_sums(y);
    sweep_kernels::zncc_row(window_sums_.ptr<float>(0),
                            window_sums_.ptr<float>(1),
                            window_sums_.ptr<float>(2),
                            inside_.ptr<float>(slot(y + radius_)) + radius_,
                            key_mean_.ptr<float>(y), inverse_std_.ptr<float>(y),
                            inverse_n, padded_width_, aggregated_.ptr<float>(y),
                            sum_.ptr<float>(y), count_.ptr<float>(y));
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
    const sweep_kernels::WinnerRow row{
        winner_.score.ptr<float>(y),  winner_.second.ptr<float>(y),
        winner_.before.ptr<float>(y), winner_.after.ptr<float>(y),
        winner_.depth.ptr<float>(y),  winner_.direction.ptr<int32_t>(y),
        winner_.plane.ptr<int32_t>(y)};
    sweep_kernels::update_winner_row(
        aggregated_.ptr<float>(y), previous_.ptr<float>(y),
        ray_dot_.ptr<float>(y), d, basin, f, plane, padded_width_, row);
  }
}

void StripSweep::finish(const std::vector<SweepDirection>& directions,
                        DepthMap* out) const {
  std::vector<Eigen::Vector3d> normals;  // K^-T n: its dot with (x, y, 1)
  for (const SweepDirection& dir : directions)
    normals.push_back(in_.key.K.inverse().transpose() * dir.normal);
  for (int y = 0; y < size_.height; ++y) {
    float* depth = out->depth.ptr<float>(rows_.start + y);
    float* score = out->score.ptr<float>(rows_.start + y);
    float* margin = out->margin.ptr<float>(rows_.start + y);
    for (int x = 0; x < size_.width; ++x) {
      const int f = winner_.direction.at<int>(y, x);
      if (f < 0) continue;
      const SweepDirection& dir = directions[f];
      const int plane = winner_.plane.at<int>(y, x);
      const float best = winner_.score.at<float>(y, x);
      const float before = winner_.before.at<float>(y, x);
      const float after = winner_.after.at<float>(y, x);
      score[x] = best;
      margin[x] = best - std::max(winner_.second.at<float>(y, x), -1.0f);
      // A winner on the first or last plane may lie beyond the range.
      if (plane == 0 || plane == dir.planes - 1 || before <= kNoScore ||
          after <= kNoScore || best < in_.options.min_score ||
          margin[x] < in_.options.min_margin) {
        continue;
      }
      const double curvature = before - 2.0 * best + after;
      const double shift =
          curvature < 0
              ? std::clamp(0.5 * (before - after) / curvature, -0.5, 0.5)
              : 0.0;
      const double d = 1 / inverse_offset(dir, plane + shift);
      const Eigen::Vector3d& n = normals[f];
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
  if (options.window < 3 || options.window > kMaxWindow ||
      options.window % 2 == 0)
    throw std::invalid_argument(
        "sweep_planes: window must be odd, from 3 to 31");
  for (const DenseView* n : neighbours) {
    if (n->bgr.size() != key.bgr.size() || n->bgr.type() != CV_8UC3)
      throw std::invalid_argument(
          "sweep_planes: neighbour images must match the key's size");
  }
}

// Drops the depths whose points lie farther along `direction`'s normal
// than its last plane.
void clip_beyond(const DenseView& key, const SweepDirection& direction,
                 DepthMap* map) {
  const Eigen::Vector3d n = key.K.inverse().transpose() * direction.normal;
  for (int y = 0; y < map->depth.rows; ++y) {
    float* depth = map->depth.ptr<float>(y);
    for (int x = 0; x < map->depth.cols; ++x) {
      if (depth[x] > 0 &&
          depth[x] * (n.x() * x + n.y() * y + n.z()) > direction.d_far)
        depth[x] = 0;
    }
  }
}

// What every path's map goes through last. Sky has no depth, whatever the
// sweep found there (dense/sky_mask.h). Nor has a point beyond the
// fronto-parallel range (the key's sparse depths, widened: a plane of
// another direction meets rays near its horizon far beyond anything the key
// sees) or below the ground's range (measured through the ground, which
// no surface can be seen through).
void finish_map(const DenseView& key,
                const std::vector<const DenseView*>& neighbours,
                const std::vector<SweepDirection>& directions,
                const PlaneSweepOptions& options, DepthMap* map) {
  if (options.min_triangulation_deg > 0) {
    std::vector<Eigen::Vector3d> centres;
    for (const DenseView* n : neighbours) centres.push_back(n->centre());
    map->depth.setTo(
        0, narrow_triangulation(*map, centres, options.min_triangulation_deg));
  }
  if (options.sky_max_texture > 0)
    map->depth.setTo(0, sky_mask(key.bgr, options.sky_max_texture));
  for (const SweepDirection& direction : directions) {
    if (&direction == &directions.front() || direction.ground)
      clip_beyond(key, direction, map);
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
    finish_map(key, neighbours, directions, options, &map);
    return map;
  }
  const SweepInputs inputs = sweep_inputs(key, neighbours, options);
  const int rows = key.bgr.rows;
  // Strip boundaries on kSumBlock rows (see window_sums).
  const int blocks = (rows + kSumBlock - 1) / kSumBlock;
  const int strips =
      std::clamp(blocks / 2, 1, 4 * std::max(1, cv::getNumThreads()));
  auto boundary = [&](int s) {
    return std::min(rows, blocks * s / strips * kSumBlock);
  };
  auto sweep_strips = [&](const cv::Range& range) {
    for (int s = range.start; s < range.end; ++s) {
      StripSweep strip(inputs, cv::Range(boundary(s), boundary(s + 1)));
      strip.run(directions);
      strip.finish(directions, &map);
    }
  };
  if (!options.parallel) {
    sweep_strips(cv::Range(0, strips));
  } else if (!options.keep_parallel) {
    cv::parallel_for_(cv::Range(0, strips), sweep_strips);
  } else {
    const int group = std::max(1, cv::getNumThreads());
    for (int s = 0; s < strips; s += group) {
      const cv::Range range(s, std::min(strips, s + group));
      if (options.keep_parallel())
        cv::parallel_for_(range, sweep_strips);
      else
        sweep_strips(range);
    }
  }
  finish_map(key, neighbours, directions, options, &map);
  return map;
}

}  // namespace arscout::engine
