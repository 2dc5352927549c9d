#include "mesh/view_selection.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <unordered_map>

#include <Eigen/Geometry>

#include "mesh/rasterize.h"

namespace arscout::engine::mesh {
namespace {

struct Candidate {
  int view = -1;
  float score = 0;  // the face's area in the view's pixels
};

Eigen::Matrix3d scaled(const Eigen::Matrix3d& K, double s) {
  Eigen::Matrix3d out = K;
  out.row(0) *= s;
  out.row(1) *= s;
  out(0, 2) = (K(0, 2) + 0.5) * s - 0.5;
  out(1, 2) = (K(1, 2) + 0.5) * s - 0.5;
  return out;
}

// Whether the depth image (of intrinsics K_depth) shows something nearer
// than `z` at the projection of camera point `c`.
bool hidden_in(const cv::Mat& depth, const Eigen::Matrix3d& K_depth,
               const Eigen::Vector3d& c, double tolerance) {
  const Eigen::Vector3d h = K_depth * c;
  const int x = static_cast<int>(std::lround(h.x() / h.z()));
  const int y = static_cast<int>(std::lround(h.y() / h.z()));
  if (x < 0 || y < 0 || x >= depth.cols || y >= depth.rows) return false;
  const float d = depth.at<float>(y, x);
  return d > 0 && d < c.z() * (1 - tolerance);
}

// The faces `view` sees and their scores.
void score_view(const TexturedMesh& mesh, const TextureView& view, int index,
                const TextureOptions& options,
                std::vector<std::vector<Candidate>>& candidates) {
  const double s = static_cast<double>(options.raster_long_side) /
                   std::max(view.bgr.cols, view.bgr.rows);
  const cv::Size raster_size(static_cast<int>(std::lround(view.bgr.cols * s)),
                             static_cast<int>(std::lround(view.bgr.rows * s)));
  const Eigen::Matrix3d K_raster = scaled(view.K, s);
  const MeshRaster raster = rasterize(mesh.positions, mesh.indices, K_raster,
                                      view.R, view.t, raster_size);
  const Eigen::Matrix3d K_depth =
      view.depth.empty() ? view.K
                         : scaled(view.K, static_cast<double>(view.depth.cols) /
                                              view.bgr.cols);
  const Eigen::Vector3d centre = -view.R.transpose() * view.t;
  const auto& p = mesh.positions;
  for (std::size_t f = 0; f * 3 + 2 < mesh.indices.size(); ++f) {
    const Eigen::Vector3d a = p[mesh.indices[3 * f]].cast<double>();
    const Eigen::Vector3d b = p[mesh.indices[3 * f + 1]].cast<double>();
    const Eigen::Vector3d c = p[mesh.indices[3 * f + 2]].cast<double>();
    const Eigen::Vector3d mid = (a + b + c) / 3;
    const Eigen::Vector3d normal = (b - a).cross(c - a).normalized();
    const Eigen::Vector3d ray = (centre - mid).normalized();
    if (normal.dot(ray) < options.min_cos) continue;
    std::array<Eigen::Vector2d, 3> px;
    bool inside = true;
    for (int k = 0; k < 3 && inside; ++k) {
      const Eigen::Vector3d cam = view.R * (k == 0   ? a
                                            : k == 1 ? b
                                                     : c) +
                                  view.t;
      const Eigen::Vector3d h = view.K * cam;
      px[k] = h.head<2>() / h.z();
      inside = cam.z() > 0 && px[k].x() >= 1 && px[k].y() >= 1 &&
               px[k].x() < view.bgr.cols - 2 && px[k].y() < view.bgr.rows - 2;
    }
    if (!inside) continue;
    const Eigen::Vector3d cam_mid = view.R * mid + view.t;
    if (hidden_in(raster.depth, K_raster, cam_mid, options.occlusion_tolerance))
      continue;
    if (!view.depth.empty() &&
        hidden_in(view.depth, K_depth, cam_mid, options.occlusion_tolerance))
      continue;
    const double area =
        0.5 * std::abs((px[1] - px[0]).x() * (px[2] - px[0]).y() -
                       (px[1] - px[0]).y() * (px[2] - px[0]).x());
    candidates[f].push_back({index, static_cast<float>(area)});
  }
}

float score_of(const std::vector<Candidate>& candidates, int view) {
  for (const Candidate& c : candidates)
    if (c.view == view) return c.score;
  return -1;
}

// One round: each face takes the label that best mixes its own score
// (relative to its best) and agreement with its neighbours.
std::vector<int> smooth(
    const std::vector<int>& labels,
    const std::vector<std::vector<Candidate>>& candidates,
    const std::vector<std::vector<std::uint32_t>>& neighbours) {
  constexpr float kAgreement = 0.35f;  // per agreeing neighbour
  std::vector<int> out = labels;
  for (std::size_t f = 0; f < labels.size(); ++f) {
    if (labels[f] < 0) continue;
    const float best = score_of(candidates[f], labels[f]);
    std::map<int, int> agreeing;
    for (const std::uint32_t g : neighbours[f])
      if (labels[g] >= 0) ++agreeing[labels[g]];
    float chosen_value =
        1 + kAgreement * static_cast<float>(agreeing[labels[f]]);
    for (const auto& [view, count] : agreeing) {
      const float score = score_of(candidates[f], view);
      if (score < 0) continue;
      const float value = score / best + kAgreement * static_cast<float>(count);
      if (value > chosen_value + 1e-6f) {
        chosen_value = value;
        out[f] = view;
      }
    }
  }
  return out;
}

}  // namespace

std::vector<std::vector<std::uint32_t>> face_neighbours(
    const std::vector<std::uint32_t>& indices, std::size_t vertices) {
  const std::size_t faces = indices.size() / 3;
  std::unordered_map<std::uint64_t, std::uint32_t> first_face;
  first_face.reserve(indices.size());
  std::vector<std::vector<std::uint32_t>> out(faces);
  for (std::uint32_t f = 0; f < faces; ++f)
    for (int k = 0; k < 3; ++k) {
      std::uint64_t a = indices[3 * f + k], b = indices[3 * f + (k + 1) % 3];
      if (a > b) std::swap(a, b);
      const auto [it, added] = first_face.try_emplace(a * vertices + b, f);
      if (added) continue;
      out[f].push_back(it->second);
      out[it->second].push_back(f);
    }
  return out;
}

std::vector<int> select_views(
    const TexturedMesh& mesh, const std::vector<TextureView>& views,
    const std::vector<std::vector<std::uint32_t>>& neighbours,
    const TextureOptions& options) {
  std::vector<std::vector<Candidate>> candidates(mesh.triangles());
  for (std::size_t v = 0; v < views.size(); ++v)
    score_view(mesh, views[v], static_cast<int>(v), options, candidates);
  std::vector<int> labels(mesh.triangles(), -1);
  for (std::size_t f = 0; f < labels.size(); ++f) {
    float best = 0;
    for (const Candidate& c : candidates[f])
      if (c.score > best) {
        best = c.score;
        labels[f] = c.view;
      }
  }
  for (int round = 0; round < options.smoothing_rounds; ++round)
    labels = smooth(labels, candidates, neighbours);
  return labels;
}

}  // namespace arscout::engine::mesh
