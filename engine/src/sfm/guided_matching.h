// Matching two posed images along their epipolar lines: the candidates for
// a keypoint are those of the other image near its epipolar line, so the
// descriptor only has to tell apart a handful of corners, not thousands.
// This is how the refinement matches the weaker corners that an increment
// leaves out (sfm/densify.cpp), like COLMAP's guided matching.
#pragma once

#include <utility>
#include <vector>

#include "scene/scene.h"

namespace arscout::engine {

struct GuidedMatchOptions {
  // A candidate's largest distance from the epipolar line, in the second
  // image's working pixels: the increments' essential-matrix threshold.
  // At 2 px the matches' keypoints fitted the true poses worse (median
  // 0.26 against 0.16 px) and bent seed 31's first 100 photos twice as
  // much (bench/RESULTS.md, "Issue 35, seventeenth stop").
  double max_epipolar_px = 1.0;
  // Lowe's ratio: the nearest candidate against the next nearest keypoint
  // in a wider band along the line (kCompetitorBandPx, guided_matching.cpp);
  // a keypoint with no competitor there is not matched.
  double ratio = 0.8;
};

// Matches keypoints `from_a` of image `a` with keypoints `from_b` of image
// `b` (indices into each image's keypoints and descriptors), both images
// posed, through the epipolar geometry of their current poses: each
// keypoint of `from_a` takes the nearest candidate by descriptor distance
// when it passes the ratio test; a keypoint of `b` chosen by several keeps
// the nearest. Returns (keypoint of a, keypoint of b) in the order of
// `from_a`. Depth and parallax are not checked (triangulation does that).
std::vector<std::pair<int, int>> guided_matches(
    const SceneCamera& camera_a, const SceneImage& a,
    const std::vector<int>& from_a, const SceneCamera& camera_b,
    const SceneImage& b, const std::vector<int>& from_b,
    const GuidedMatchOptions& options);

}  // namespace arscout::engine
