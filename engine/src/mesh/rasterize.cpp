#include "mesh/rasterize.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace arscout::engine::mesh {
namespace {

struct Projected {
  Eigen::Vector2d pixel;
  double inv_z = 0;
};

// Edge function: twice the signed area of (a, b, p).
double edge(const Eigen::Vector2d& a, const Eigen::Vector2d& b,
            const Eigen::Vector2d& p) {
  return (b.x() - a.x()) * (p.y() - a.y()) - (b.y() - a.y()) * (p.x() - a.x());
}

void draw(const std::array<Projected, 3>& v, int index, MeshRaster& out) {
  const double area = edge(v[0].pixel, v[1].pixel, v[2].pixel);
  if (std::abs(area) < 1e-12) return;
  const int x0 = std::max(
      0, static_cast<int>(std::ceil(
             std::min({v[0].pixel.x(), v[1].pixel.x(), v[2].pixel.x()}))));
  const int x1 = std::min(
      out.depth.cols - 1,
      static_cast<int>(std::floor(
          std::max({v[0].pixel.x(), v[1].pixel.x(), v[2].pixel.x()}))));
  const int y0 = std::max(
      0, static_cast<int>(std::ceil(
             std::min({v[0].pixel.y(), v[1].pixel.y(), v[2].pixel.y()}))));
  const int y1 = std::min(
      out.depth.rows - 1,
      static_cast<int>(std::floor(
          std::max({v[0].pixel.y(), v[1].pixel.y(), v[2].pixel.y()}))));
  for (int y = y0; y <= y1; ++y) {
    auto* depth = out.depth.ptr<float>(y);
    auto* triangle = out.triangle.ptr<std::int32_t>(y);
    auto* weights = out.weights.ptr<cv::Vec2f>(y);
    for (int x = x0; x <= x1; ++x) {
      const Eigen::Vector2d p(x, y);
      const double b0 = edge(v[1].pixel, v[2].pixel, p) / area;
      const double b1 = edge(v[2].pixel, v[0].pixel, p) / area;
      const double b2 = 1 - b0 - b1;
      if (b0 < 0 || b1 < 0 || b2 < 0) continue;
      const double inv_z = b0 * v[0].inv_z + b1 * v[1].inv_z + b2 * v[2].inv_z;
      const float z = static_cast<float>(1 / inv_z);
      if (depth[x] != 0 && depth[x] <= z) continue;
      depth[x] = z;
      triangle[x] = index;
      weights[x] = cv::Vec2f(static_cast<float>(b1 * v[1].inv_z / inv_z),
                             static_cast<float>(b2 * v[2].inv_z / inv_z));
    }
  }
}

}  // namespace

MeshRaster rasterize(const std::vector<Eigen::Vector3f>& positions,
                     const std::vector<std::uint32_t>& indices,
                     const Eigen::Matrix3d& K, const Eigen::Matrix3d& R,
                     const Eigen::Vector3d& t, cv::Size size, double near_z) {
  MeshRaster out;
  out.depth = cv::Mat::zeros(size, CV_32F);
  out.triangle = cv::Mat(size, CV_32S, cv::Scalar(-1));
  out.weights = cv::Mat::zeros(size, CV_32FC2);
  std::vector<Projected> projected(positions.size());
  std::vector<bool> in_front(positions.size());
  for (std::size_t i = 0; i < positions.size(); ++i) {
    const Eigen::Vector3d c = R * positions[i].cast<double>() + t;
    in_front[i] = c.z() > near_z;
    if (!in_front[i]) continue;
    const Eigen::Vector3d h = K * c;
    projected[i] = {h.head<2>() / h.z(), 1 / c.z()};
  }
  for (std::size_t f = 0; f + 2 < indices.size(); f += 3) {
    const std::uint32_t a = indices[f], b = indices[f + 1], c = indices[f + 2];
    if (!in_front[a] || !in_front[b] || !in_front[c]) continue;
    draw({projected[a], projected[b], projected[c]}, static_cast<int>(f / 3),
         out);
  }
  return out;
}

}  // namespace arscout::engine::mesh
