// A z-buffered triangle rasteriser on the CPU: which triangle each pixel of
// a pinhole view sees, and where on it. The texturing's occlusion test and
// the textured rendering (render_mesh) both read it.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace arscout::engine::mesh {

struct MeshRaster {
  cv::Mat depth;     // CV_32F: camera z of the nearest surface, 0 where none
  cv::Mat triangle;  // CV_32S: its triangle (index / 3), -1 where none
  // Perspective-correct barycentric weights of the triangle's 2nd and 3rd
  // vertices at the pixel centre (the 1st has 1 - both).
  cv::Mat weights;  // CV_32FC2
};

// Rasterises the triangles through K [R | t] into an image of `size`;
// pixel centres at integer coordinates. Triangles with a vertex behind
// near_z are skipped (no clipping: the views here look at the surface
// from outside). Both windings are drawn.
MeshRaster rasterize(const std::vector<Eigen::Vector3f>& positions,
                     const std::vector<std::uint32_t>& indices,
                     const Eigen::Matrix3d& K, const Eigen::Matrix3d& R,
                     const Eigen::Vector3d& t, cv::Size size,
                     double near_z = 1e-3);

}  // namespace arscout::engine::mesh
