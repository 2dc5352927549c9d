#include "arscout/engine/point_render.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <Eigen/Geometry>

namespace arscout::engine {

PointRendering render_points(const std::vector<ColoredPoint>& points,
                             const Eigen::Matrix3d& K, const Eigen::Matrix3d& R,
                             const Eigen::Vector3d& t, cv::Size size,
                             int radius) {
  PointRendering out;
  out.bgr = cv::Mat::zeros(size, CV_8UC3);
  out.depth = cv::Mat::zeros(size, CV_32F);
  const Eigen::Matrix3d KR = K * R;
  const Eigen::Vector3d Kt = K * t;
  for (const ColoredPoint& p : points) {
    const Eigen::Vector3d h = KR * Eigen::Vector3d(p.x, p.y, p.z) + Kt;
    if (h.z() <= 0) continue;
    const int u = static_cast<int>(std::lround(h.x() / h.z()));
    const int v = static_cast<int>(std::lround(h.y() / h.z()));
    const float z = static_cast<float>(h.z());
    for (int y = std::max(0, v - radius);
         y <= std::min(size.height - 1, v + radius); ++y) {
      float* depth = out.depth.ptr<float>(y);
      cv::Vec3b* bgr = out.bgr.ptr<cv::Vec3b>(y);
      for (int x = std::max(0, u - radius);
           x <= std::min(size.width - 1, u + radius); ++x) {
        if (depth[x] > 0 && depth[x] <= z) continue;
        depth[x] = z;
        bgr[x] = cv::Vec3b(p.b, p.g, p.r);
      }
    }
  }
  return out;
}

namespace {

double median_of(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

}  // namespace

PinholeView orbit_view(const std::vector<ColoredPoint>& points,
                       double azimuth_deg, double elevation_deg,
                       cv::Size size) {
  if (points.empty())
    throw std::invalid_argument("orbit view: the point cloud is empty");
  if (size.width <= 0 || size.height <= 0)
    throw std::invalid_argument("orbit view: empty image size");
  std::vector<double> xs, ys, zs;
  for (const ColoredPoint& p : points) {
    xs.push_back(p.x);
    ys.push_back(p.y);
    zs.push_back(p.z);
  }
  // The median, not the mean: a few stray points far out must not move the
  // view off the scene.
  const Eigen::Vector3d centre(median_of(xs), median_of(ys), median_of(zs));
  std::vector<double> distances;
  for (const ColoredPoint& p : points)
    distances.push_back((Eigen::Vector3d(p.x, p.y, p.z) - centre).norm());
  std::sort(distances.begin(), distances.end());
  const double radius = std::max(
      distances[static_cast<size_t>(0.95 * (distances.size() - 1))], 1e-6);

  constexpr double kPi = 3.14159265358979323846;
  const double f = size.width / (2 * std::tan(30 * kPi / 180));
  const double half_fov =
      std::atan(std::min(size.width, size.height) / (2 * f));
  const double distance = 1.05 * radius / std::sin(half_fov);
  const double az = azimuth_deg * kPi / 180;
  const double el = std::clamp(elevation_deg, -89.0, 89.0) * kPi / 180;
  const Eigen::Vector3d towards_camera(
      std::cos(el) * std::sin(az), std::cos(el) * std::cos(az), std::sin(el));
  const Eigen::Vector3d C = centre + distance * towards_camera;
  const Eigen::Vector3d forward = -towards_camera;
  const Eigen::Vector3d right =
      forward.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d down = forward.cross(right);
  PinholeView view;
  view.R.row(0) = right.transpose();
  view.R.row(1) = down.transpose();
  view.R.row(2) = forward.transpose();
  view.t = -view.R * C;
  view.K << f, 0, size.width / 2.0, 0, f, size.height / 2.0, 0, 0, 1;
  view.size = size;
  return view;
}

}  // namespace arscout::engine
