#include "features/keypoint_refinement.h"

#include <algorithm>
#include <array>
#include <cmath>

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

namespace arscout::engine {
namespace {

constexpr int kCentre = kPatchSide / 2;
constexpr int kHalfWindow = 3;
constexpr int kWindow = (2 * kHalfWindow + 1) * (2 * kHalfWindow + 1);
// Harris peaks of one spot seen from two places differ by up to a few
// pixels. Accepting more (17 px patches, 3 px, correlation 0.7) moves more
// observations (88 % against 74 % on the 150-photo walk) but also moves
// some onto a look-alike nearby: on the 400-photo walk (seed 1) one photo
// then failed to register and the chain broke for 266 photos
// (bench/RESULTS.md). These are the settings measured whole.
constexpr double kMaxShift = 1.5;
constexpr double kMinCorrelation = 0.8;
// How far the window may move while iterating and stay inside the patch
// with a pixel to spare for the gradient.
constexpr double kMaxSearch = kCentre - kHalfWindow - 1;
constexpr int kIterations = 30;
// Shift change, pixels, below which the alignment has converged (the
// patches are 8-bit, finer steps are noise).
constexpr double kConverged = 0.01;

// A stored patch as numbers, with its central-difference gradient
// (computed once: an alignment samples the patch up to 30 times), and
// bilinear samples of both.
class Patch {
 public:
  explicit Patch(const uchar* values) {
    for (int i = 0; i < kPixels; ++i) value_[i] = values[i];
    for (int y = 1; y + 1 < kPatchSide; ++y) {
      for (int x = 1; x + 1 < kPatchSide; ++x) {
        gradient_[index(x, y)] = {0.5 * (at(x + 1, y) - at(x - 1, y)),
                                  0.5 * (at(x, y + 1) - at(x, y - 1))};
      }
    }
  }
  double at(int x, int y) const { return value_[index(x, y)]; }
  // Value and gradient at (x, y); pixels outside [1, kPatchSide - 2] are
  // clamped into it.
  Eigen::Vector3d sample(double x, double y) const {
    const int x0 = static_cast<int>(std::floor(x));
    const int y0 = static_cast<int>(std::floor(y));
    const double fx = x - x0;
    const double fy = y - y0;
    Eigen::Vector3d out = Eigen::Vector3d::Zero();
    const double weights[4] = {(1 - fx) * (1 - fy), fx * (1 - fy),
                               (1 - fx) * fy, fx * fy};
    const int xs[4] = {x0, x0 + 1, x0, x0 + 1};
    const int ys[4] = {y0, y0, y0 + 1, y0 + 1};
    for (int k = 0; k < 4; ++k) {
      const int i = index(std::clamp(xs[k], 1, kPatchSide - 2),
                          std::clamp(ys[k], 1, kPatchSide - 2));
      out += weights[k] *
             Eigen::Vector3d(value_[i], gradient_[i][0], gradient_[i][1]);
    }
    return out;
  }

 private:
  static constexpr int kPixels = kPatchSide * kPatchSide;
  static int index(int x, int y) { return y * kPatchSide + x; }

  std::array<double, kPixels> value_{};
  std::array<std::array<double, 2>, kPixels> gradient_{};
};

// The reference window and the target's samples at `shift`.
struct Windows {
  std::array<double, kWindow> reference{};
  std::array<Eigen::Vector3d, kWindow> target{};
};

// The reference window, centred `offset` off the patch's centre: sampled
// once per alignment (bilinear sampling at whole pixels gives the stored
// values exactly).
Windows reference_window(const Patch& reference,
                         const Eigen::Vector2d& offset) {
  Windows w;
  int i = 0;
  for (int v = -kHalfWindow; v <= kHalfWindow; ++v) {
    for (int u = -kHalfWindow; u <= kHalfWindow; ++u, ++i) {
      w.reference[i] =
          reference.sample(kCentre + u + offset.x(), kCentre + v + offset.y())
              .x();
    }
  }
  return w;
}

// `w` with the target's samples at `shift`.
const Windows& sample_target(Windows& w, const Patch& target,
                             const Eigen::Vector2d& shift) {
  int i = 0;
  for (int v = -kHalfWindow; v <= kHalfWindow; ++v) {
    for (int u = -kHalfWindow; u <= kHalfWindow; ++u, ++i) {
      w.target[i] =
          target.sample(kCentre + u + shift.x(), kCentre + v + shift.y());
    }
  }
  return w;
}

double correlation(const Windows& w) {
  double sr = 0, st = 0, srr = 0, stt = 0, srt = 0;
  for (int i = 0; i < kWindow; ++i) {
    const double r = w.reference[i];
    const double t = w.target[i].x();
    sr += r, st += t, srr += r * r, stt += t * t, srt += r * t;
  }
  const double n = kWindow;
  const double var_r = srr - sr * sr / n;
  const double var_t = stt - st * st / n;
  if (var_r <= 1e-9 || var_t <= 1e-9) return 0;
  return (srt - sr * st / n) / std::sqrt(var_r * var_t);
}

// One Gauss-Newton step on (shift x, shift y, gain, bias); false when the
// window has too little texture to fix a shift.
bool gauss_newton_step(const Windows& w, Eigen::Vector4d& params) {
  Eigen::Matrix4d H = Eigen::Matrix4d::Zero();
  Eigen::Vector4d g = Eigen::Vector4d::Zero();
  for (int i = 0; i < kWindow; ++i) {
    const Eigen::Vector3d& t = w.target[i];
    const double e = t.x() - params[2] * w.reference[i] - params[3];
    const Eigen::Vector4d J(t.y(), t.z(), -w.reference[i], -1);
    H += J * J.transpose();
    g += J * e;
  }
  const Eigen::LDLT<Eigen::Matrix4d> solver(H);
  if (solver.info() != Eigen::Success || !solver.isPositive()) return false;
  const Eigen::Vector4d step = -solver.solve(g);
  if (!step.allFinite()) return false;
  params += step;
  return true;
}

}  // namespace

cv::Mat extract_patches(const cv::Mat& gray,
                        const std::vector<Eigen::Vector2d>& keypoints) {
  cv::Mat patches(static_cast<int>(keypoints.size()), kPatchSide * kPatchSide,
                  CV_8U);
  cv::Mat patch;
  for (size_t k = 0; k < keypoints.size(); ++k) {
    // Bilinear, the border repeated; (kPatchSide - 1) / 2 is the centre.
    cv::getRectSubPix(gray, cv::Size(kPatchSide, kPatchSide),
                      cv::Point2f(static_cast<float>(keypoints[k].x()),
                                  static_cast<float>(keypoints[k].y())),
                      patch, CV_8U);
    patch.reshape(1, 1).copyTo(patches.row(static_cast<int>(k)));
  }
  return patches;
}

std::optional<Eigen::Vector2d> align_patch(
    const uchar* reference, const uchar* target,
    const Eigen::Vector2d& reference_offset) {
  if (reference_offset.norm() > kMaxShift) return std::nullopt;
  const Patch ref(reference);
  const Patch tgt(target);
  Windows windows = reference_window(ref, reference_offset);
  Eigen::Vector4d params(0, 0, 1, 0);  // shift x, shift y, gain, bias
  bool converged = false;
  for (int it = 0; it < kIterations && !converged; ++it) {
    const Eigen::Vector2d before = params.head<2>();
    if (!gauss_newton_step(sample_target(windows, tgt, before), params))
      return std::nullopt;
    if (params.head<2>().norm() > kMaxSearch) return std::nullopt;
    converged = (params.head<2>() - before).norm() < kConverged;
  }
  const Eigen::Vector2d shift = params.head<2>();
  if (!converged || shift.norm() > kMaxShift ||
      correlation(sample_target(windows, tgt, shift)) < kMinCorrelation) {
    return std::nullopt;
  }
  return shift;
}

}  // namespace arscout::engine
