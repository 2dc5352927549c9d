// Components: separately reconstructed parts of one site. A walk with a
// break (a corner, a door) or a scout starting elsewhere leaves photos that
// match each other but no point of the model; they start a component of
// their own, placed in the site's ENU frame through their fixes, and a
// later photo that matches two components merges them: a robust similarity
// from their common points (3D-3D), the seam's tracks welded and adjusted
// in a bounded window, the whole left to the global refinement.
#include <algorithm>
#include <cmath>
#include <set>

#include "estimators/bundle_adjuster.h"
#include "estimators/estimators.h"
#include "sfm/mapper.h"
#include "stopwatch.h"

namespace arscout::engine {
namespace {

// A component starts from a pair among the newest loose photos (those no
// component reaches): where a scout is now is where the new part grows.
constexpr size_t kStartWindow = 12;
// Pairs tried per increment, so that loose photos cost a bounded time.
constexpr size_t kStartAttempts = 2;
// A pair must triangulate this many points to start anything (as the
// first model's).
constexpr size_t kStartPoints = 50;
// Registrations tried for a new component's third photo.
constexpr int kThirdAttempts = 5;
// The 3D-3D inlier tolerance of a merge, as a share of the spread of the
// common points (metres, both components being in ENU).
constexpr double kMergeTolerance = 0.05;
constexpr double kMergeToleranceMin = 0.05;
// A merge's similarity may fix a new component's scale (from 3 noisy fixes)
// by this factor at most either way.
constexpr double kMergeScaleRange = 5;
// Images of the seam adjusted after a merge.
constexpr size_t kSeamImages = 12;

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

// Loose photos: unregistered, with a fix, and too few 2D-3D matches to any
// component for a pose. The best-conditioned pair among the newest of them
// starts a component once the model is in ENU (a component is placed there
// on its own, so the frame must be ENU already).
bool IncrementalMapper::start_component(std::vector<int>& registered) {
  if (!options_.multiple_models || !scene_.initialized ||
      !scene_.geo_registered)
    return false;
  std::vector<int> loose;
  for (int i = static_cast<int>(scene_.images.size()) - 1;
       i >= 0 && loose.size() < kStartWindow; --i) {
    const SceneImage& image = scene_.images[i];
    if (image.removed || image.registered || !image.gps) continue;
    bool reached = false;
    for (const auto& [component, corr] : correspondences_by_component(i))
      reached |= static_cast<int>(corr.size()) >= options_.min_pose_inliers;
    if (!reached) loose.push_back(i);
  }
  if (loose.size() < 3) return false;
  const std::set<int> window(loose.begin(), loose.end());
  const auto ranked = initial_pairs([&](int a, int b) {
    return window.count(a) && window.count(b) &&
           !scene_.failed_component_pairs.count({a, b});
  });
  for (size_t i = 0; i < ranked.size() && i < kStartAttempts; ++i) {
    if (try_component_pair(ranked[i].first, ranked[i].second, registered))
      return true;
    scene_.failed_component_pairs.insert(ranked[i]);
  }
  return false;
}

// A new component from a pair and a third photo that registers on its
// points, then moved into ENU by their fixes and adjusted there; on any
// failure nothing of it is left.
bool IncrementalMapper::try_component_pair(int a, int b,
                                           std::vector<int>& registered) {
  const ImagePair& pair = scene_.pairs.at({a, b});
  const int component = scene_.next_component;
  SceneImage& first = scene_.images[a];
  SceneImage& second = scene_.images[b];
  first.q.setIdentity();
  first.t.setZero();
  second.q = Eigen::Quaterniond(pair.R).normalized();
  second.t = pair.t;
  for (SceneImage* image : {&first, &second}) {
    image->registered = true;
    image->component = component;
  }
  const size_t before = scene_.points.size();
  for (const auto& [ka, kb] : pair.matches)
    triangulate_pair_match({a, ka}, {b, kb});
  const int third = scene_.points.size() >= before + kStartPoints
                        ? register_third(component)
                        : -1;
  if (third < 0 || !geo_register(component, false)) {
    dissolve_component(component);
    return false;
  }
  ++scene_.next_component;
  for (SceneImage* image : {&first, &second}) {
    image->status = CaptureStatus::kRegistered;
    image->reason.clear();
    image->pose_inliers = static_cast<int>(pair.matches.size());
  }
  refine_keypoints(b);
  refine_keypoints(third);
  const std::vector<int> members{a, b, third};
  adjust_bundle(scene_, members, false, bundle_options(15));
  filter_points(members);
  registered.insert(registered.end(), members.begin(), members.end());
  scene_.registered_at_last_global_ba = 0;  // refine() is due
  return true;
}

// The photo with the most 2D-3D matches to a young component registered
// on them and triangulated; -1 when none registers.
int IncrementalMapper::register_third(int component) {
  std::set<int> failed;
  for (int attempt = 0; attempt < kThirdAttempts; ++attempt) {
    size_t count = 0;
    int found = component;
    const int best = next_image(failed, &count, &found, component);
    if (best < 0 || static_cast<int>(count) < options_.min_pose_inliers)
      return -1;
    if (register_image(best, component)) {
      triangulate_image(best);
      return best;
    }
    failed.insert(best);
  }
  return -1;
}

// Unregisters a component's photos and removes its points.
void IncrementalMapper::dissolve_component(int component) {
  std::vector<int64_t> points;
  for (const auto& [id, point] : scene_.points) {
    if (scene_.component_of_point(id) == component) points.push_back(id);
  }
  for (int64_t id : points) scene_.remove_point(id);
  for (SceneImage& image : scene_.images) {
    if (!image.registered || image.component != component) continue;
    image.registered = false;
    if (image.status == CaptureStatus::kRegistered)
      image.status = CaptureStatus::kPending;
    image.q.setIdentity();
    image.t.setZero();
  }
}

// A newly registered photo whose matches reach another component's points
// as well merges the two.
void IncrementalMapper::merge_through(int index) {
  for (const auto& [other, corr] : correspondences_by_component(index)) {
    const int mine = scene_.images[index].component;
    if (other == mine ||
        static_cast<int>(corr.size()) < options_.min_pose_inliers ||
        !scene_.component_sizes().count(other))
      continue;
    if (merge_components(mine, other, index)) ++components_merged_;
  }
}

// The smaller component moves onto the larger by a robust similarity from
// their common points; false (nothing changed) when too few agree.
bool IncrementalMapper::merge_components(int a, int b, int via) {
  const auto sizes = scene_.component_sizes();
  const int keep = sizes.at(a) >= sizes.at(b) ? a : b;
  const int gone = keep == a ? b : a;
  const auto same = common_points(scene_, keep, gone);
  if (static_cast<int>(same.size()) < options_.min_pose_inliers) return false;
  std::vector<Eigen::Vector3d> from, to;
  for (const auto& [kept, moved] : same) {
    to.push_back(scene_.points.at(kept).xyz);
    from.push_back(scene_.points.at(moved).xyz);
  }
  const double tolerance =
      std::max(kMergeToleranceMin, kMergeTolerance * spread(to));
  std::vector<int> inliers;
  const auto sim = estimate_similarity(from, to, tolerance,
                                       static_cast<uint64_t>(via), &inliers);
  if (!sim || static_cast<int>(inliers.size()) < options_.min_pose_inliers ||
      3 * inliers.size() < same.size() ||
      !(sim->scale > 1 / kMergeScaleRange && sim->scale < kMergeScaleRange))
    return false;
  transform_model(*sim, gone);
  for (SceneImage& image : scene_.images) {
    if (image.registered && image.component == gone) image.component = keep;
  }
  std::vector<std::pair<int64_t, int64_t>> agreed;
  for (int i : inliers) agreed.push_back(same[i]);
  weld_seam(keep, agreed);
  return true;
}

// After a merge: the common points become one track each, the photos
// along the seam triangulate their matches across it, and a bounded
// adjustment of the seam follows; the global refinement is due.
void IncrementalMapper::weld_seam(
    int component, const std::vector<std::pair<int64_t, int64_t>>& same) {
  std::map<int, int> on_seam;  // image -> welded observations
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
  if (global_inline()) adjust_global();
}

}  // namespace arscout::engine
