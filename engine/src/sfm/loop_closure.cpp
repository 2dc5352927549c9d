#include "sfm/loop_closure.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <set>
#include <vector>

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
};

SplitMatches split_matches(const Scene& scene, int image, int min_age) {
  SplitMatches split;
  std::set<int> seen_old, seen_recent;
  const int component = scene.images[image].component;
  for (const auto& [other, pair] : scene.pairs_of(image)) {
    const SceneImage& partner = scene.images[other];
    if (!partner.registered || partner.component != component) continue;
    const bool old = image - other > min_age;
    if (old) split.newest_old = std::max(split.newest_old, other);
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

// Moves each registered image of `last`'s component after `first` by its
// share of the correction (rising linearly to 1 at `last`), and each point
// by the mean share of the images observing it.
void spread(Scene& scene, const Correction& correction, int first, int last) {
  const int component = scene.images[last].component;
  auto weight = [&](int k) {
    if (k <= first || scene.images[k].component != component) return 0.0;
    if (k >= last) return 1.0;
    return static_cast<double>(k - first) / (last - first);
  };
  for (auto& [id, point] : scene.points) {
    double sum = 0;
    for (const Observation& obs : point.track) sum += weight(obs.image);
    const double w = point.track.empty() ? 0 : sum / point.track.size();
    if (w > 0) point.xyz = correction.apply(point.xyz, w);
  }
  for (size_t k = 0; k < scene.images.size(); ++k) {
    SceneImage& image = scene.images[k];
    const double w = weight(static_cast<int>(k));
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

}  // namespace

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
  spread(scene, correction, split.newest_old, image);
  result.closed = true;
  return result;
}

}  // namespace arscout::engine
