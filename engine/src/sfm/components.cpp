// Components: separately reconstructed parts of one site. A walk with a
// break (a corner, a door) or a scout starting elsewhere leaves photos that
// match each other but no point of the model; they start a component of
// their own, placed in the site's ENU frame through their fixes
// (components.cpp), and a later photo that links two components merges
// them (component_merge.cpp).
#include <algorithm>
#include <map>
#include <set>

#include "estimators/bundle_adjuster.h"
#include "sfm/mapper.h"

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
  const int third = place_pair(a, b, pair, component) >= kStartPoints
                        ? register_third(component)
                        : -1;
  if (third < 0 || !geo_register(component, false)) {
    dissolve_component(component);
    return false;
  }
  ++scene_.next_component;
  for (SceneImage* image : {&scene_.images[a], &scene_.images[b]}) {
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
  scene_.merge_sweep_due = true;
  // Loose photos reach no component one by one; together the new one's
  // may (the photos either side of a break).
  for (int member : members) merge_through(member);
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

// Retires the small components that stopped growing (ReconstructionOptions::
// retire_component_below, _after), never the largest: every component
// costs each new photo a matching pass, and a stalled fragment is more
// likely a wrong start than a place worth a part of its own. When a
// component last grew is read from its newest photo's place in the site's
// order, so that replaying a feed retires the same ones.
void IncrementalMapper::retire_stalled_components() {
  const size_t stalled_after =
      static_cast<size_t>(std::max(1, options_.retire_component_after));
  const std::map<int, int> sizes = scene_.component_sizes();
  if (sizes.size() < 2) return;
  int largest = sizes.begin()->first;
  for (const auto& [component, size] : sizes)
    if (size > sizes.at(largest)) largest = component;
  std::map<int, size_t> newest;
  for (size_t i = 0; i < scene_.images.size(); ++i) {
    if (scene_.images[i].registered) newest[scene_.images[i].component] = i;
  }
  for (const auto& [component, size] : sizes) {
    if (component == largest || size >= options_.retire_component_below ||
        newest[component] + stalled_after >= scene_.images.size())
      continue;
    std::vector<int> members;
    for (size_t i = 0; i < scene_.images.size(); ++i) {
      const SceneImage& image = scene_.images[i];
      if (image.registered && image.component == component)
        members.push_back(static_cast<int>(i));
    }
    dissolve_component(component);
    ++components_retired_;
    // Together they start nothing again: a new photo must join them.
    for (int a : members)
      for (int b : members)
        if (a < b) scene_.failed_component_pairs.insert({a, b});
    for (int member : members) {
      scene_.images[member].reason =
          "its component of " + std::to_string(size) +
          " photos stopped growing and was retired; it is retried when a "
          "component grows near it";
    }
  }
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

}  // namespace arscout::engine
