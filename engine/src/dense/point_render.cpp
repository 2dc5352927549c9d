#include "arscout/engine/point_render.h"

#include <algorithm>
#include <cmath>

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

}  // namespace arscout::engine
