#include "sfm/loop_closure.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <set>
#include <unordered_map>
#include <vector>

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>

#include "estimators/estimators.h"

namespace arscout::engine {
namespace {

// (keypoint of the image, point it matches)
using Correspondences = std::vector<std::pair<int, int64_t>>;

// The image's 2D-3D matches through its verified pairs, split by the age
// of the partner: old (a loop) or recent (the chain it was added along).
struct SplitMatches {
  Correspondences old_points, recent_points;
  int newest_old = -1;
  std::vector<int> old_images;
};

SplitMatches split_matches(const Scene& scene, int image, int min_age) {
  SplitMatches split;
  std::set<int> seen_old, seen_recent;
  const int component = scene.images[image].component;
  for (const auto& [other, pair] : scene.pairs_of(image)) {
    const SceneImage& partner = scene.images[other];
    if (!partner.registered || partner.component != component) continue;
    const bool old = image - other > min_age;
    if (old) {
      split.newest_old = std::max(split.newest_old, other);
      split.old_images.push_back(other);
    }
    Correspondences& out = old ? split.old_points : split.recent_points;
    std::set<int>& seen = old ? seen_old : seen_recent;
    for (const auto& [mine, theirs] : oriented_matches(image, other, *pair)) {
      const int64_t point = partner.point_of[theirs];
      if (point >= 0 && seen.insert(mine).second) out.emplace_back(mine, point);
    }
  }
  return split;
}

std::optional<AbsolutePose> pose_from(const Scene& scene, int image,
                                      const Correspondences& matches,
                                      const ReconstructionOptions& options) {
  if (static_cast<int>(matches.size()) < options.min_pose_inliers)
    return std::nullopt;
  const SceneImage& view = scene.images[image];
  const SceneCamera& camera = scene.cameras[view.camera];
  std::vector<Eigen::Vector3d> world;
  std::vector<Eigen::Vector2d> points;
  for (const auto& [keypoint, point] : matches) {
    world.push_back(scene.points.at(point).xyz);
    points.push_back(normalize(camera, view.keypoints[keypoint]));
  }
  return estimate_absolute_pose(world, points,
                                options.max_reprojection_px / camera.params[0],
                                options.min_pose_inliers);
}

// How many of the matches the image's current pose explains.
int explained(const Scene& scene, int image, const Correspondences& matches,
              double max_px) {
  const SceneImage& view = scene.images[image];
  const SceneCamera& camera = scene.cameras[view.camera];
  int count = 0;
  for (const auto& [keypoint, point] : matches) {
    Eigen::Vector2d pixel;
    if (project(camera, view, scene.points.at(point).xyz, &pixel) &&
        (pixel - view.keypoints[keypoint]).norm() <= max_px)
      ++count;
  }
  return count;
}

// The rigid motion taking a camera from its chain pose to its loop pose,
// applied in part: weight 0 leaves a point, 1 moves it all the way.
struct Correction {
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d from = Eigen::Vector3d::Zero();  // the chain's centre
  Eigen::Vector3d to = Eigen::Vector3d::Zero();    // the loop's centre

  Eigen::Quaterniond turn(double w) const {
    return Eigen::Quaterniond::Identity().slerp(w, rotation);
  }
  Eigen::Vector3d apply(const Eigen::Vector3d& x, double w) const {
    return turn(w) * (x - from) + from + w * (to - from);
  }
};

// Moves each registered image by its share of the correction, and each
// point by the mean share of the images observing it.
void spread(Scene& scene, const Correction& correction,
            const std::vector<double>& shares) {
  for (auto& [id, point] : scene.points) {
    double sum = 0;
    for (const Observation& obs : point.track) sum += shares[obs.image];
    const double w = point.track.empty() ? 0 : sum / point.track.size();
    if (w > 0) point.xyz = correction.apply(point.xyz, w);
  }
  for (size_t k = 0; k < scene.images.size(); ++k) {
    SceneImage& image = scene.images[k];
    const double w = shares[k];
    if (!image.registered || w == 0) continue;
    const Eigen::Vector3d centre = correction.apply(image.centre(), w);
    image.q = (image.q * correction.turn(w).conjugate()).normalized();
    image.t = -(image.q * centre);
  }
}

// A loop pose far from the image's own fix is a false match (repeated
// texture elsewhere), not drift.
bool plausible(const Scene& scene, const SceneImage& image,
               const Eigen::Vector3d& centre) {
  if (!scene.geo_registered || !image.gps) return true;
  const double limit = std::max(3 * std::sqrt(2.0) * image.gps->h_acc, 5.0);
  return (centre - image.gps_enu).head<2>().norm() <= limit;
}

// How many points each pair of registered images of `component` both
// observe, keyed by (lower index, higher index).
using Links = std::unordered_map<uint64_t, int>;

uint64_t link_key(int a, int b) {
  return (static_cast<uint64_t>(a) << 32) | static_cast<uint32_t>(b);
}

Links covisibility(const Scene& scene, int component) {
  Links links;
  std::vector<int> seen;
  for (const auto& [id, point] : scene.points) {
    seen.clear();
    for (const Observation& obs : point.track) {
      const SceneImage& view = scene.images[obs.image];
      if (view.registered && view.component == component)
        seen.push_back(obs.image);
    }
    std::sort(seen.begin(), seen.end());
    seen.erase(std::unique(seen.begin(), seen.end()), seen.end());
    for (size_t i = 0; i < seen.size(); ++i)
      for (size_t j = i + 1; j < seen.size(); ++j)
        ++links[link_key(seen[i], seen[j])];
  }
  return links;
}

// The graph Laplacian's equations for the free images (the rows of
// `free_row`, -1 where pinned) with the pinned ones' shares
// (`pinned_shares`) moved to the right-hand side; a whisker of stiffness to 0
// keeps images without links (their share is then 0) from making it singular.
struct HarmonicSystem {
  Eigen::SparseMatrix<double> laplacian;
  Eigen::VectorXd rhs;
};

HarmonicSystem harmonic_system(const Links& links,
                               const std::vector<int>& free_row,
                               const std::vector<double>& pinned_shares,
                               int rows) {
  std::vector<Eigen::Triplet<double>> entries;
  Eigen::VectorXd diagonal = Eigen::VectorXd::Zero(rows);
  HarmonicSystem system{Eigen::SparseMatrix<double>(rows, rows),
                        Eigen::VectorXd::Zero(rows)};
  for (const auto& [key, count] : links) {
    const int ends[2] = {static_cast<int>(key >> 32),
                         static_cast<int>(key & 0xffffffffu)};
    for (int side = 0; side < 2; ++side) {
      const int row = free_row[ends[side]], other = ends[1 - side];
      if (row < 0) continue;
      diagonal[row] += count;
      if (free_row[other] >= 0)
        entries.emplace_back(row, free_row[other], -count);
      else
        system.rhs[row] += count * pinned_shares[other];
    }
  }
  for (int row = 0; row < rows; ++row)
    entries.emplace_back(row, row, diagonal[row] * (1 + 1e-9) + 1e-12);
  system.laplacian.setFromTriplets(entries.begin(), entries.end());
  return system;
}

}  // namespace

std::vector<double> loop_shares(const Scene& scene, const std::vector<int>& old,
                                int image) {
  const int n = static_cast<int>(scene.images.size());
  std::vector<double> shares(n, 0.0);
  shares[image] = 1;
  std::vector<int> free_row(n, -1), free_images;
  std::vector<bool> pinned(n, false);
  pinned[image] = true;
  for (int k : old) pinned[k] = true;
  const int component = scene.images[image].component;
  for (int k = 0; k < n; ++k) {
    const SceneImage& view = scene.images[k];
    if (!view.registered || view.component != component || pinned[k]) continue;
    free_row[k] = static_cast<int>(free_images.size());
    free_images.push_back(k);
  }
  if (free_images.empty()) return shares;
  const HarmonicSystem system =
      harmonic_system(covisibility(scene, component), free_row, shares,
                      static_cast<int>(free_images.size()));
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(system.laplacian);
  const Eigen::VectorXd solved = solver.solve(system.rhs);
  if (solver.info() != Eigen::Success) return shares;
  for (size_t row = 0; row < free_images.size(); ++row)
    shares[free_images[row]] = std::clamp(solved[row], 0.0, 1.0);
  return shares;
}

LoopClosure close_loop(Scene& scene, int image,
                       const ReconstructionOptions& options) {
  LoopClosure result;
  const SplitMatches split = split_matches(scene, image, options.loop_min_age);
  const auto from_old = pose_from(scene, image, split.old_points, options);
  if (!from_old) return result;
  result.old_image = split.newest_old;
  result.old_inliers = static_cast<int>(from_old->inliers.size());
  const double max_px = options.max_reprojection_px;
  // Most of what the old points say already agrees: tracks merge as they
  // are, nothing has drifted.
  if (explained(scene, image, split.old_points, max_px) >=
      0.8 * result.old_inliers)
    return result;
  SceneImage& view = scene.images[image];
  if (auto chain = pose_from(scene, image, split.recent_points, options)) {
    view.q = chain->q;
    view.t = chain->t;
  }
  Correction correction;
  correction.rotation = (from_old->q.conjugate() * view.q).normalized();
  correction.from = view.centre();
  correction.to = -(from_old->q.conjugate() * from_old->t);
  if (!plausible(scene, view, correction.to)) return result;
  result.correction_m = (correction.to - correction.from).norm();
  result.correction_deg =
      correction.rotation.angularDistance(Eigen::Quaterniond::Identity()) *
      180 / M_PI;
  spread(scene, correction, loop_shares(scene, split.old_images, image));
  result.closed = true;
  return result;
}

}  // namespace arscout::engine
