// Merging components: a robust similarity between their frames (from
// common positions, or from photos posed in both), the smaller moved onto
// the larger, the seam's tracks welded and adjusted in a bounded window,
// the whole left to the global refinement (sfm/mapper.h, docs/engine.md).
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <tuple>

#include "estimators/bundle_adjuster.h"
#include "estimators/estimators.h"
#include "runtime/stopwatch.h"
#include "sfm/fixes.h"
#include "sfm/mapper.h"

namespace arscout::engine {
namespace {

// The 3D-3D inlier tolerance of a merge, as a share of the spread of the
// common points (metres, both components being in ENU).
constexpr double kMergeTolerance = 0.05;
constexpr double kMergeToleranceMin = 0.05;
// A merge's similarity may fix a new component's scale (from 3 noisy fixes)
// by this factor at most either way.
constexpr double kMergeScaleRange = 5;
// Hinges (photos posed in both components) must stand this far apart,
// metres, to fix the scale between them, and agree on the rotation to
// this angle.
constexpr double kHingeSpan = 5.0;
constexpr double kHingeAngleRad = 2.0 * M_PI / 180;
// Images of the seam triangulated and adjusted after a merge.
constexpr size_t kSeamImages = 24;

// Points (keep's, gone's) that matches between registered images of the
// two components say are one.
std::vector<std::pair<int64_t, int64_t>> common_points(const Scene& scene,
                                                       int keep, int gone) {
  std::vector<std::pair<int64_t, int64_t>> same;
  std::set<std::pair<int64_t, int64_t>> seen;
  for (const auto& [key, pair] : scene.pairs) {
    const SceneImage& x = scene.images[key.first];
    const SceneImage& y = scene.images[key.second];
    if (!x.registered || !y.registered) continue;
    const bool x_keeps = x.component == keep && y.component == gone;
    if (!x_keeps && !(x.component == gone && y.component == keep)) continue;
    for (const auto& [kx, ky] : pair.matches) {
      const int64_t px = x.point_of[kx];
      const int64_t py = y.point_of[ky];
      if (px < 0 || py < 0) continue;
      const auto ids = x_keeps ? std::pair{px, py} : std::pair{py, px};
      if (seen.insert(ids).second) same.push_back(ids);
    }
  }
  return same;
}

// The median distance of the points from their centroid.
double spread(const std::vector<Eigen::Vector3d>& points) {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : points) centroid += p;
  centroid /= static_cast<double>(std::max<size_t>(1, points.size()));
  std::vector<double> distances;
  for (const Eigen::Vector3d& p : points)
    distances.push_back((p - centroid).norm());
  if (distances.empty()) return 0;
  std::nth_element(distances.begin(), distances.begin() + distances.size() / 2,
                   distances.end());
  return distances[distances.size() / 2];
}

}  // namespace

// A newly registered photo whose matches reach another component merges
// the two where a similarity holds: from its own 2D-3D matches there, from
// the common points of the verified pairs between the two components'
// photos (a break in a walk: the photos on either side of a corner share
// few points each, but together enough), from hinges, or from one pair.
void IncrementalMapper::merge_through(int index) {
  const auto reached = correspondences_by_component(index);
  for (const auto& [other, corr] : reached) {
    const int mine = scene_.images[index].component;
    if (other == mine || !scene_.component_sizes().count(other)) continue;
    // Every component a photo reaches is worth a try: its matches there
    // come through a verified pair, which may fix the similarity alone
    // when too few of them reach points (sfm/pair_bridge.cpp).
    if (merge_components(mine, other, index)) ++components_merged_;
  }
}

// Components that registered photos link, merged while the site is idle:
// a photo registered before the component it links grew to meet it (or
// before a merge gave its partner a new component) merges nothing when it
// comes. For each pair of components, the photo with the most 2D-3D
// matches to the other is the bridge. Returns the merges made.
int IncrementalMapper::sweep_merges(const std::function<bool()>& stop) {
  int merged = 0;
  bool again = scene_.merge_sweep_due;
  while (again && scene_.component_sizes().size() > 1 && !(stop && stop())) {
    again = false;
    // (component, other) -> (2D-3D matches, photo)
    std::map<std::pair<int, int>, std::pair<size_t, int>> bridges;
    for (size_t i = 0; i < scene_.images.size(); ++i) {
      const SceneImage& image = scene_.images[i];
      if (!image.registered) continue;
      for (const auto& [other, corr] :
           correspondences_by_component(static_cast<int>(i))) {
        if (other == image.component || corr.empty()) continue;
        auto& best = bridges[{image.component, other}];
        if (corr.size() > best.first) best = {corr.size(), static_cast<int>(i)};
      }
    }
    // Components that only verified pairs link (no photo matches a point
    // of the other yet): the pair bridge may still merge them.
    for (const auto& [key, pair] : scene_.pairs) {
      const SceneImage& x = scene_.images[key.first];
      const SceneImage& y = scene_.images[key.second];
      if (x.registered && y.registered && x.component != y.component)
        bridges.try_emplace({x.component, y.component}, 0, key.first);
    }
    for (const auto& [key, bridge] : bridges) {
      const auto [mine, other] = key;
      if (merge_components(mine, other, bridge.second)) {
        ++merged;
        again = true;  // the ids and the bridges changed
        break;
      }
    }
  }
  scene_.merge_sweep_due = false;
  components_merged_ += merged;
  return merged;
}

// Where the photo's matched keypoints lie in one component's frame, with
// the photo at `posed`'s pose there: the point of the photo or of the
// partner's keypoint where there is one, else the match triangulated from
// the two poses (with the parallax and reprojection checks of a new point).
std::map<int, Eigen::Vector3d> IncrementalMapper::bridge_points(
    int via, const SceneImage& posed, int component) const {
  std::map<int, Eigen::Vector3d> result;
  const SceneImage& image = scene_.images[via];
  if (image.registered && image.component == component) {
    for (size_t k = 0; k < image.point_of.size(); ++k)
      if (image.point_of[k] >= 0)
        result[static_cast<int>(k)] = scene_.points.at(image.point_of[k]).xyz;
  }
  for (const auto& [other, pair] : scene_.pairs_of(via)) {
    const SceneImage& partner = scene_.images[other];
    if (!partner.registered || partner.component != component) continue;
    for (const auto& [mine, theirs] : oriented_matches(via, other, *pair)) {
      if (result.count(mine)) continue;
      if (partner.point_of[theirs] >= 0) {
        result[mine] = scene_.points.at(partner.point_of[theirs]).xyz;
        continue;
      }
      if (const auto X =
              triangulated(posed, {via, mine}, partner, {other, theirs}))
        result[mine] = *X;
    }
  }
  return result;
}

// Pairs of positions (keep's frame, gone's frame) of one place: the points
// their registered photos' matches say are one, and the photo `via`'s
// matched keypoints placed in both frames (it is registered in one and
// posed in the other by its 2D-3D matches there): a photo that bridges a
// gap often shares no triangulated point with the other side yet.
void IncrementalMapper::common_positions(
    int keep, int gone, int via, std::vector<Eigen::Vector3d>* in_keep,
    std::vector<Eigen::Vector3d>* in_gone,
    std::vector<std::pair<int64_t, int64_t>>* same) const {
  *same = common_points(scene_, keep, gone);
  for (const auto& [kept, moved] : *same) {
    in_keep->push_back(scene_.points.at(kept).xyz);
    in_gone->push_back(scene_.points.at(moved).xyz);
  }
  const SceneImage& image = scene_.images[via];
  const int other = image.component == keep ? gone : keep;
  const auto pose = pose_in(via, other);
  if (!pose) return;
  SceneImage posed;
  posed.q = pose->q;
  posed.t = pose->t;
  const auto in_own = bridge_points(via, image, image.component);
  const auto in_other = bridge_points(via, posed, other);
  for (const auto& [keypoint, position] : in_own) {
    const auto it = in_other.find(keypoint);
    if (it == in_other.end()) continue;
    const bool own_kept = image.component == keep;
    in_keep->push_back(own_kept ? position : it->second);
    in_gone->push_back(own_kept ? it->second : position);
  }
}

// The smaller component moves onto the larger by a robust similarity;
// false (nothing changed) when none holds. The similarity comes from common
// positions (3D-3D) where the photos' matches give enough; at a corner, where
// each photo shares one wall with one side and another wall with the other,
// they give almost none, and the photos that the other side's points pose
// (hinges: one camera in both frames) give it instead, when two of them stand
// far enough apart to fix the scale (a walk broken at two corners, or two
// scouts whose walks meet at both ends).
bool IncrementalMapper::merge_components(int a, int b, int via) {
  const auto sizes = scene_.component_sizes();
  const int keep = sizes.at(a) >= sizes.at(b) ? a : b;
  const int gone = keep == a ? b : a;
  std::vector<std::pair<int64_t, int64_t>> agreed;
  std::vector<int> seam{via};
  auto sim = point_similarity(keep, gone, via, &agreed);
  if (!sim) {
    const std::vector<Hinge> posed = hinges(keep, gone);
    for (const Hinge& hinge : posed) seam.push_back(hinge.image);
    sim = hinge_similarity(posed);
  }
  if (!sim) sim = pair_similarity(keep, gone);
  if (!sim || !merge_agrees_with_fixes(scene_, keep, gone, *sim)) return false;
  // The photos with verified pairs across the seam: once one component,
  // their matches there become tracks that tie the two sides together.
  for (const auto& [key, pair] : scene_.pairs) {
    const SceneImage& x = scene_.images[key.first];
    const SceneImage& y = scene_.images[key.second];
    if (x.registered && y.registered &&
        ((x.component == keep && y.component == gone) ||
         (x.component == gone && y.component == keep))) {
      seam.push_back(key.first);
      seam.push_back(key.second);
    }
  }
  transform_model(*sim, gone);
  for (SceneImage& image : scene_.images) {
    if (image.registered && image.component == gone) image.component = keep;
  }
  weld_seam(keep, seam, agreed);
  return true;
}

// The similarity from gone's frame to keep's by their common positions,
// and the common points among its inliers (which become one track each).
std::optional<Similarity> IncrementalMapper::point_similarity(
    int keep, int gone, int via,
    std::vector<std::pair<int64_t, int64_t>>* agreed) const {
  std::vector<Eigen::Vector3d> from, to;
  std::vector<std::pair<int64_t, int64_t>> same;
  common_positions(keep, gone, via, &to, &from, &same);
  if (static_cast<int>(to.size()) < options_.min_pose_inliers)
    return std::nullopt;
  const double tolerance =
      std::max(kMergeToleranceMin, kMergeTolerance * spread(to));
  std::vector<int> inliers;
  const auto sim = estimate_similarity(from, to, tolerance,
                                       static_cast<uint64_t>(via), &inliers);
  if (!sim || static_cast<int>(inliers.size()) < options_.min_pose_inliers ||
      3 * inliers.size() < to.size() ||
      !(sim->scale > 1 / kMergeScaleRange && sim->scale < kMergeScaleRange))
    return std::nullopt;
  for (int i : inliers)
    if (static_cast<size_t>(i) < same.size()) agreed->push_back(same[i]);
  return sim;
}

// Photos of either component that the other's points pose: each is one
// camera seen in both frames.
std::vector<IncrementalMapper::Hinge> IncrementalMapper::hinges(
    int keep, int gone) const {
  std::vector<Hinge> result;
  for (size_t i = 0; i < scene_.images.size(); ++i) {
    const SceneImage& image = scene_.images[i];
    if (!image.registered ||
        (image.component != keep && image.component != gone))
      continue;
    const int other = image.component == keep ? gone : keep;
    const auto pose = pose_in(static_cast<int>(i), other);
    if (!pose) continue;
    SceneImage there;
    there.q = pose->q;
    there.t = pose->t;
    const bool kept = image.component == keep;
    result.push_back({static_cast<int>(i), kept ? image.q : there.q,
                      kept ? image.centre() : there.centre(),
                      kept ? there.q : image.q,
                      kept ? there.centre() : image.centre()});
  }
  return result;
}

// The similarity that two or more hinges fix: the rotation from their
// cameras (averaged), the scale from the farthest two (at least
// kHingeSpan apart in both frames), the translation from their centres;
// none unless every hinge agrees with it.
std::optional<Similarity> IncrementalMapper::hinge_similarity(
    const std::vector<Hinge>& hinges) const {
  if (hinges.size() < 2) return std::nullopt;
  size_t first = 0, second = 1;
  double span = 0;
  for (size_t i = 0; i < hinges.size(); ++i) {
    for (size_t j = i + 1; j < hinges.size(); ++j) {
      const double d = (hinges[i].keep_centre - hinges[j].keep_centre).norm();
      if (d > span) std::tie(span, first, second) = std::tuple{d, i, j};
    }
  }
  const double gone_span =
      (hinges[first].gone_centre - hinges[second].gone_centre).norm();
  if (span < kHingeSpan || gone_span < kHingeSpan / kMergeScaleRange)
    return std::nullopt;
  Similarity sim;
  sim.scale = span / gone_span;
  if (!(sim.scale > 1 / kMergeScaleRange && sim.scale < kMergeScaleRange))
    return std::nullopt;
  // x_keep = s R x_gone + t, and a camera's R_keep R = R_gone.
  Eigen::Vector4d sum = Eigen::Vector4d::Zero();
  const Eigen::Quaterniond reference =
      hinges[first].keep_q.conjugate() * hinges[first].gone_q;
  for (const Hinge& h : hinges) {
    const Eigen::Quaterniond r = h.keep_q.conjugate() * h.gone_q;
    sum += (r.dot(reference) < 0 ? -1.0 : 1.0) * r.coeffs();
  }
  const Eigen::Quaterniond rotation = Eigen::Quaterniond(sum).normalized();
  sim.R = rotation.toRotationMatrix();
  sim.t = Eigen::Vector3d::Zero();
  for (const Hinge& h : hinges)
    sim.t += h.keep_centre - sim.scale * sim.R * h.gone_centre;
  sim.t /= static_cast<double>(hinges.size());
  const double tolerance = std::max(kMergeToleranceMin, kMergeTolerance * span);
  for (const Hinge& h : hinges) {
    if ((sim.apply(h.gone_centre) - h.keep_centre).norm() > tolerance ||
        (h.keep_q.conjugate() * h.gone_q).angularDistance(rotation) >
            kHingeAngleRad)
      return std::nullopt;
  }
  return sim;
}

// The photo's pose in a component it is not registered in, from its 2D-3D
// matches there; none when they are too few or do not agree.
std::optional<AbsolutePose> IncrementalMapper::pose_in(int index,
                                                       int component) const {
  const SceneImage& image = scene_.images[index];
  const SceneCamera& camera = scene_.cameras[image.camera];
  std::vector<Eigen::Vector3d> world;
  std::vector<Eigen::Vector2d> rays;
  for (const auto& [keypoint, point] : correspondences(index, component)) {
    world.push_back(scene_.points.at(point).xyz);
    rays.push_back(normalize(camera, image.keypoints[keypoint]));
  }
  if (static_cast<int>(world.size()) < options_.min_pose_inliers)
    return std::nullopt;
  return estimate_absolute_pose(world, rays, threshold_normalized(index),
                                options_.min_pose_inliers);
}

// After a merge: the common points become one track each, the photos
// along the seam triangulate their matches across it, and a bounded
// adjustment of the seam follows, the union is placed by its fixes, and the
// global refinement is due.
void IncrementalMapper::weld_seam(
    int component, const std::vector<int>& bridges,
    const std::vector<std::pair<int64_t, int64_t>>& same) {
  std::map<int, int> on_seam;  // image -> welded observations
  for (int image : bridges)    // first
    on_seam[image] = std::numeric_limits<int>::max() / 2;
  for (const auto& [kept, moved] : same) {
    if (!scene_.points.count(kept) || !scene_.points.count(moved)) continue;
    for (int64_t id : {kept, moved}) {
      for (const Observation& obs : scene_.points.at(id).track)
        ++on_seam[obs.image];
    }
    merge_tracks(kept, moved);
  }
  std::vector<std::pair<int, int>> ranked;
  for (const auto& [image, count] : on_seam) ranked.push_back({-count, image});
  std::sort(ranked.begin(), ranked.end());
  std::vector<int> seam;
  for (size_t i = 0; i < ranked.size() && i < kSeamImages; ++i)
    seam.push_back(ranked[i].second);
  for (int image : seam) {
    if (scene_.images[image].component == component) triangulate_image(image);
  }
  {
    StageClock clock(timings_.bundle_adjustment_s);
    BundleOptions ba = bundle_options(15);
    ba.max_fixed_images = options_.local_ba_fixed;
    ba.max_track_observations = options_.local_ba_track;
    adjust_bundle(scene_, seam, false, ba);
    filter_points(seam);
  }
  scene_.registered_at_last_global_ba = 0;  // refine() is due
  scene_.unsettled_refine_rounds = 0;
  scene_.refinement_urgent = true;
  // The union placed by its fixes at once: by the inline global adjustment
  // while the model is small, else as after a registration (the global
  // refinement that would do it may wait long on a busy site).
  if (global_inline())
    adjust_global();
  else
    geo_register(component, scene_.geo_registered);
}

}  // namespace arscout::engine
