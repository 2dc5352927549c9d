// Weak links of a walk tied back into the model. Where a walk passes a
// building's corner, a photo may share too little with the one before it
// to register; the next ones start a component, which later merges with
// the others where they meet. Around a block the components form a ring,
// and the ring closes with one seam never used for a merge: its two sides
// share no point, so the whole loop's drift lands there (seed 53's block:
// 14.8 cm between two photos 1.2 m apart, after six refinement rounds;
// bench/RESULTS.md, "Issue 35, twentieth stop"). The pair's verified
// matches are still there. As COLMAP completes and retriangulates
// under-reconstructed pairs with a looser angular error, they are linked
// into tracks here with a looser reprojection limit, and the round that
// follows weighs residuals up to the usual limit (not the keypoints' loss,
// under which pixels-off points weigh nothing), so that they pull the seam
// shut.
#include <vector>

#include "runtime/stopwatch.h"
#include "sfm/mapper.h"

namespace arscout::engine {
namespace {

// A pair with fewer verified matches says too little to tie anything
// (COLMAP's two-view minimum).
constexpr size_t kLoosePairMatches = 15;
// A pair is loose when fewer than one match in this many lies on a point
// both images hold (COLMAP's re_min_ratio, 0.2).
constexpr size_t kLooseShare = 5;
// The looser limit, in multiples of max_reprojection_px.
constexpr double kLooseReprojection = 10;
// Rounds that may find one pair strained. A seam's links hold once the
// round they weigh in pulls it shut (seed 53's closed in one); a pair
// whose matches are false stays strained, and each try costs a round at
// the wider loss.
constexpr int kStrainedTries = 2;

bool loose(const SceneImage& a, const SceneImage& b, const ImagePair& pair) {
  if (pair.matches.size() < kLoosePairMatches) return false;
  size_t shared = 0;
  for (const auto& [first, second] : pair.matches)
    shared += a.point_of[first] >= 0 && a.point_of[first] == b.point_of[second];
  return shared * kLooseShare < pair.matches.size();
}

bool tried_out(const Scene& scene, const std::pair<int, int>& key) {
  const auto tries = scene.strained_tries.find(key);
  return tries != scene.strained_tries.end() && tries->second >= kStrainedTries;
}

}  // namespace

IncrementalMapper::LooseTies IncrementalMapper::tie_loose_pairs(
    const std::function<bool()>& stop) {
  StageClock clock(timings_.triangulation_s);
  const double limit = options_.max_reprojection_px * kLooseReprojection;
  LooseTies ties;
  visit_linked_pairs(
      stop, [&](const std::pair<int, int>& key, const ImagePair& pair) {
        const SceneImage& a = scene_.images[key.first];
        const SceneImage& b = scene_.images[key.second];
        if (tried_out(scene_, key) || !loose(a, b, pair)) return;
        const int strained_before = ties.strained;
        for (const auto& [first, second] : pair.matches) {
          const int64_t held = a.point_of[first];
          if (held >= 0 && held == b.point_of[second]) continue;
          const Observation in_a{key.first, first};
          const Observation in_b{key.second, second};
          if (link_match(in_a, in_b, options_.max_reprojection_px)) {
            ++ties.linked;
          } else if (link_match(in_a, in_b, limit)) {
            ++ties.linked;
            ++ties.strained;
          }
        }
        if (ties.strained > strained_before) ++scene_.strained_tries[key];
      });
  return ties;
}

}  // namespace arscout::engine
