// The weaker corners into the model, off the latency path. An increment
// matches only each photo's strongest ReconstructionOptions::match_features
// corners: matching and the local adjustment grow faster than the corners,
// and four scouts leave a photo under a second. The model's accuracy grows
// with the corners in it (docs/engine.md, "How many corners"), so the
// refinement matches the rest along the epipolar lines of the registered
// pairs, whose poses it knows by then: few candidates per corner, so it
// costs a fraction of matching them by descriptor alone.
#include <set>
#include <vector>

#include "features/keypoint_refinement.h"
#include "runtime/stopwatch.h"
#include "sfm/guided_matching.h"
#include "sfm/mapper.h"

namespace arscout::engine {
namespace {

// Pairs densified between two looks at `stop`.
constexpr int kPairsPerStopCheck = 8;

// Keypoints of `image` that none of `matches`' sides (`side` 0: first, 1:
// second) holds already.
std::vector<int> unmatched_keypoints(
    const SceneImage& image, const std::vector<std::pair<int, int>>& matches,
    int side) {
  std::vector<bool> held(image.keypoints.size(), false);
  for (const auto& [first, second] : matches)
    held[side == 0 ? first : second] = true;
  std::vector<int> result;
  for (size_t k = 0; k < held.size(); ++k)
    if (!held[k]) result.push_back(static_cast<int>(k));
  return result;
}

// Keypoints of `image` that patch alignment has moved already: their
// positions are no longer the detected ones the patches are centred on, so
// they are not aligned again.
std::set<int> refined_keypoints(const SceneImage& image) {
  std::set<int> result;
  for (const auto& [keypoint, position] : image.refined_keypoints)
    result.insert(keypoint);
  return result;
}

}  // namespace

int IncrementalMapper::densify_tracks(const std::function<bool()>& stop) {
  StageClock clock(timings_.triangulation_s);
  int linked = 0;
  int densified = 0;
  for (auto& [key, pair] : scene_.pairs) {
    if (scene_.densified_pairs.count(key)) continue;
    const SceneImage& a = scene_.images[key.first];
    const SceneImage& b = scene_.images[key.second];
    if (!a.registered || !b.registered || a.component != b.component) continue;
    if (stop && ++densified % kPairsPerStopCheck == 0 && stop()) break;
    linked += densify_pair(key, pair);
    scene_.densified_pairs.insert(key);
  }
  return linked;
}

// One pair's guided matches with at least one weak corner (strong with
// strong the increment's descriptor matching has tried), added to the
// pair's matches and linked into tracks. Returns the matches linked.
int IncrementalMapper::densify_pair(const std::pair<int, int>& key,
                                    ImagePair& pair) {
  const int strong = options_.match_features;
  const SceneImage& a = scene_.images[key.first];
  const SceneImage& b = scene_.images[key.second];
  if (static_cast<int>(a.keypoints.size()) <= strong &&
      static_cast<int>(b.keypoints.size()) <= strong)
    return 0;
  GuidedMatchOptions guided;
  guided.ratio = options_.ratio;
  const auto found = guided_matches(
      scene_.cameras[a.camera], a, unmatched_keypoints(a, pair.matches, 0),
      scene_.cameras[b.camera], b, unmatched_keypoints(b, pair.matches, 1),
      guided);
  const std::set<int> refined_a = refined_keypoints(a);
  const std::set<int> refined_b = refined_keypoints(b);
  int linked = 0;
  for (const auto& [ka, kb] : found) {
    if (ka < strong && kb < strong) continue;
    const int64_t pa = a.point_of[ka];
    const int64_t pb = b.point_of[kb];
    if (pa >= 0 && pa == pb) continue;
    pair.matches.push_back({ka, kb});
    link_match({key.first, ka}, {key.second, kb});
    if (a.point_of[ka] < 0 || a.point_of[ka] != b.point_of[kb]) continue;
    // A keypoint new to the model moves onto its track's spot, as an
    // increment's do (keypoint_refinement.h); one held already was. A weak
    // corner whose patch does not align stays out: as detected it is off
    // by about a third of a pixel, independently in each photo, which
    // bends a walk (seed 31's first 100 photos: 0.52 cm with them in, 0.26
    // cm without; bench/RESULTS.md, "Issue 35, seventeenth stop").
    const bool fits_a =
        pa >= 0 || refined_a.count(ka) || align_to_track({key.first, ka});
    const bool fits_b =
        pb >= 0 || refined_b.count(kb) || align_to_track({key.second, kb});
    if (!fits_a) scene_.remove_observation({key.first, ka});
    if (!fits_b) scene_.remove_observation({key.second, kb});
    linked += fits_a && fits_b;
  }
  return linked;
}

// Moves the keypoint of `obs` onto the spot its track's reference shows,
// unless it is the reference itself (the track's earliest observation).
// False when the patches do not align: the keypoint is then where the
// detector put it, up to a few pixels off the spot (keypoint_refinement.h).
bool IncrementalMapper::align_to_track(Observation obs) {
  SceneImage& image = scene_.images[obs.image];
  if (image.patches.rows != static_cast<int>(image.keypoints.size()))
    return true;  // a state from before patches were kept: as detected
  const int64_t point = image.point_of[obs.keypoint];
  const auto reference = track_reference(point, obs.image);
  if (!reference || reference->image > obs.image) return true;
  auto shift = align_patch(patch_of(*reference), patch_of(obs));
  if (!shift) shift = align_through_neighbour(point, *reference, obs);
  if (!shift) return false;
  image.keypoints[obs.keypoint] += *shift;
  image.refined_keypoints.emplace_back(obs.keypoint,
                                       image.keypoints[obs.keypoint]);
  return true;
}

}  // namespace arscout::engine
