#include "dense/view_coverage.h"

#include <cmath>

namespace arscout::engine {
namespace {

constexpr int kStride = 4;  // depth map pixels between samples

int cell_of(double x, double y, const CameraIntrinsics& camera) {
  if (!(x >= 0 && y >= 0 && x < camera.width && y < camera.height)) return -1;
  const int column = static_cast<int>(x * kCoverageColumns / camera.width);
  const int row = static_cast<int>(y * kCoverageRows / camera.height);
  return row * kCoverageColumns + column;
}

// Counts `map` in the cells of the view that its depths land in.
void mark_measured(const CameraIntrinsics& camera, const Eigen::Matrix3d& R,
                   const Eigen::Vector3d& t, const DepthMap& map,
                   std::vector<int>* measured) {
  std::vector<bool> marked(measured->size(), false);
  const Eigen::Matrix3d K_inverse = map.K.inverse();
  const Eigen::Matrix3d map_to_world = map.R.transpose();
  for (int y = 0; y < map.depth.rows; y += kStride) {
    const float* row = map.depth.ptr<float>(y);
    for (int x = 0; x < map.depth.cols; x += kStride) {
      if (!(row[x] > 0)) continue;
      const Eigen::Vector3d world =
          map_to_world *
          (row[x] * (K_inverse * Eigen::Vector3d(x, y, 1)) - map.t);
      const Eigen::Vector3d in_view = R * world + t;
      if (!(in_view.z() > 0)) continue;
      const int cell =
          cell_of(camera.fx * in_view.x() / in_view.z() + camera.cx,
                  camera.fy * in_view.y() / in_view.z() + camera.cy, camera);
      if (cell >= 0) marked[cell] = true;
    }
  }
  for (size_t i = 0; i < marked.size(); ++i) (*measured)[i] += marked[i];
}

}  // namespace

double measured_share(const CameraIntrinsics& camera, const Eigen::Matrix3d& R,
                      const Eigen::Vector3d& t,
                      const std::vector<std::array<double, 2>>& keypoints,
                      const std::vector<const DepthMap*>& maps) {
  if (camera.width <= 0 || camera.height <= 0) return 0;
  std::vector<bool> scene(kCoverageColumns * kCoverageRows, false);
  for (const auto& [x, y] : keypoints) {
    const int cell = cell_of(x, y, camera);
    if (cell >= 0) scene[cell] = true;
  }
  std::vector<int> measured(scene.size(), 0);  // maps per cell
  for (const DepthMap* map : maps) mark_measured(camera, R, t, *map, &measured);
  int asked = 0, answered = 0;
  for (size_t i = 0; i < scene.size(); ++i) {
    asked += scene[i];
    answered += scene[i] && measured[i] >= kCoverageMaps;
  }
  return asked == 0 ? 0 : static_cast<double>(answered) / asked;
}

}  // namespace arscout::engine
