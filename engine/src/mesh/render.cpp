// render_mesh: the textured mesh drawn into a view on the CPU.
#include <algorithm>

#include "arscout/engine/mesh.h"
#include "mesh/image_sample.h"
#include "mesh/rasterize.h"

namespace arscout::engine {
namespace {

cv::Vec3b bilinear(const cv::Mat& atlas, const Eigen::Vector2f& uv) {
  const cv::Vec3d c = mesh::sample_bilinear(atlas, uv.x() * atlas.cols - 0.5,
                                            uv.y() * atlas.rows - 0.5);
  return cv::Vec3b(cv::saturate_cast<uchar>(c[0]),
                   cv::saturate_cast<uchar>(c[1]),
                   cv::saturate_cast<uchar>(c[2]));
}

cv::Vec3b shade(const TexturedMesh& mesh, int triangle, const cv::Vec2f& w) {
  const std::uint32_t a = mesh.indices[3 * triangle],
                      b = mesh.indices[3 * triangle + 1],
                      c = mesh.indices[3 * triangle + 2];
  const float w0 = 1 - w[0] - w[1];
  if (!mesh.atlas.empty() && !mesh.uvs.empty())
    return bilinear(mesh.atlas,
                    w0 * mesh.uvs[a] + w[0] * mesh.uvs[b] + w[1] * mesh.uvs[c]);
  if (mesh.colors.empty()) return cv::Vec3b(200, 200, 200);
  cv::Vec3b out;
  for (int k = 0; k < 3; ++k)
    out[2 - k] = cv::saturate_cast<uchar>(w0 * mesh.colors[a][k] +
                                          w[0] * mesh.colors[b][k] +
                                          w[1] * mesh.colors[c][k]);
  return out;
}

}  // namespace

MeshRendering render_mesh(const TexturedMesh& mesh, const Eigen::Matrix3d& K,
                          const Eigen::Matrix3d& R, const Eigen::Vector3d& t,
                          cv::Size size) {
  const mesh::MeshRaster raster =
      mesh::rasterize(mesh.positions, mesh.indices, K, R, t, size);
  MeshRendering out;
  out.depth = raster.depth;
  out.bgr = cv::Mat::zeros(size, CV_8UC3);
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) {
      const int triangle = raster.triangle.at<std::int32_t>(y, x);
      if (triangle >= 0)
        out.bgr.at<cv::Vec3b>(y, x) =
            shade(mesh, triangle, raster.weights.at<cv::Vec2f>(y, x));
    }
  return out;
}

}  // namespace arscout::engine
