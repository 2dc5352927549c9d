#include "dense/depth_normals.h"

#include <cmath>
#include <vector>

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

namespace arscout::engine {
namespace {

// A depth within this share of its 5 x 5 median lies on the surface there.
constexpr float kSameSurface = 0.02f;

// Window sums of each of `images` (CV_64F), unnormalised.
std::vector<cv::Mat> window_sums(const std::vector<cv::Mat>& images,
                                 int radius) {
  std::vector<cv::Mat> sums;
  const cv::Size window(2 * radius + 1, 2 * radius + 1);
  for (const cv::Mat& image : images) {
    cv::Mat sum;
    cv::boxFilter(image, sum, CV_64F, window, cv::Point(-1, -1), false,
                  cv::BORDER_CONSTANT);
    sums.push_back(sum);
  }
  return sums;
}

}  // namespace

cv::Mat depth_normals(const cv::Mat& depth, const Eigen::Matrix3d& K,
                      int radius) {
  CV_Assert(depth.type() == CV_32F && radius >= 1);
  // Pixel coordinates relative to the window's centre keep the sums well
  // conditioned: sum (x - x0)^2 = sum x^2 - 2 x0 sum x + x0^2 n, and so on;
  // so the images hold coordinates relative to the map's centre and the
  // per-pixel shift is applied below.
  const double cx = depth.cols / 2.0, cy = depth.rows / 2.0;
  // Only depths on the surface around them take part: a stray depth in
  // the window (the sweep's outliers are speckles) would tilt the fit.
  cv::Mat median;
  cv::medianBlur(depth, median, 5);
  cv::Mat w(depth.size(), CV_64F), u(depth.size(), CV_64F),
      x(depth.size(), CV_64F), y(depth.size(), CV_64F);
  for (int r = 0; r < depth.rows; ++r) {
    const float* z = depth.ptr<float>(r);
    const float* m = median.ptr<float>(r);
    for (int c = 0; c < depth.cols; ++c) {
      const bool valid =
          z[c] > 0 && std::abs(z[c] - m[c]) <= kSameSurface * m[c];
      w.at<double>(r, c) = valid;
      u.at<double>(r, c) = valid ? 1.0 / z[c] : 0;
      x.at<double>(r, c) = valid ? c - cx : 0;
      y.at<double>(r, c) = valid ? r - cy : 0;
    }
  }
  const std::vector<cv::Mat> s = window_sums(
      {w, x, y, x.mul(x), y.mul(y), x.mul(y), x.mul(u), y.mul(u), u}, radius);
  const double min_count = 0.5 * (2 * radius + 1) * (2 * radius + 1);
  const Eigen::Matrix3d K_inverse = K.inverse();
  cv::Mat normals(depth.size(), CV_32FC3, cv::Scalar::all(0));
  for (int r = 0; r < depth.rows; ++r) {
    for (int c = 0; c < depth.cols; ++c) {
      const double n = s[0].at<double>(r, c);
      if (depth.at<float>(r, c) <= 0 || n < min_count) continue;
      auto at = [&](int k) { return s[k].at<double>(r, c); };
      // Coordinates relative to the pixel: X = x - x0, Y = y - y0.
      const double x0 = c - cx, y0 = r - cy;
      const double sx = at(1) - x0 * n, sy = at(2) - y0 * n;
      const double sxx = at(3) - 2 * x0 * at(1) + x0 * x0 * n;
      const double syy = at(4) - 2 * y0 * at(2) + y0 * y0 * n;
      const double sxy = at(5) - x0 * at(2) - y0 * at(1) + x0 * y0 * n;
      const double sxu = at(6) - x0 * at(8), syu = at(7) - y0 * at(8);
      Eigen::Matrix3d A;
      A << sxx, sxy, sx, sxy, syy, sy, sx, sy, n;
      const Eigen::Vector3d b(sxu, syu, at(8));
      const Eigen::Vector3d local = A.ldlt().solve(b);
      // 1/z = a X + b Y + e = a x + b y + (e - a x0' - b y0') in absolute
      // pixels, x0' = c and y0' = r.
      const Eigen::Vector3d plane(local.x(), local.y(),
                                  local.z() - local.x() * c - local.y() * r);
      Eigen::Vector3d normal = K.transpose() * plane;
      if (!(normal.norm() > 0) || !normal.allFinite()) continue;
      normal.normalize();
      // Toward the camera: the point K^-1 (c, r, 1) z lies in front.
      const Eigen::Vector3d ray = K_inverse * Eigen::Vector3d(c, r, 1);
      if (normal.dot(ray) > 0) normal = -normal;
      normals.at<cv::Vec3f>(r, c) = cv::Vec3f(static_cast<float>(normal.x()),
                                              static_cast<float>(normal.y()),
                                              static_cast<float>(normal.z()));
    }
  }
  return normals;
}

}  // namespace arscout::engine
