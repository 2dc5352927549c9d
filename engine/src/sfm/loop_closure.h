// Loop closing: when a walk comes back to where it was, the newly
// registered image matches both its recent neighbours and old captures of
// the same place, and the two sets of points disagree by the drift the
// chain of photos accumulated in between. Left alone, the new points are
// never merged with the old ones and the model holds the place twice.
//
// close_loop measures the drift at the new image (its pose from the recent
// points against its pose from the old ones), spreads the correction along
// the chain of images that links the old ones to the new one (loop_shares)
// and moves their points with them, so that the two sets of tracks agree to
// within the merge threshold; the caller then merges them and the next
// global adjustment removes what the spread left.
#pragma once

#include <vector>

#include "arscout/engine/model.h"
#include "arscout/engine/options.h"
#include "scene/scene.h"

namespace arscout::engine {

struct LoopClosure {
  bool closed = false;        // the model was moved
  int old_image = -1;         // the newest old partner (the loop's start)
  int old_inliers = 0;        // 2D-3D inliers of the pose from old points
  double correction_m = 0;    // how far the new image moved
  double correction_deg = 0;  // and turned
};

// `image` is registered. Its verified pairs with registered images of its
// component added more than `options.loop_min_age` captures earlier are its old
// partners; nothing happens when they give fewer than
// `options.min_pose_inliers` agreeing 2D-3D matches, or when the image's pose
// already explains them (within `options.max_reprojection_px`).
LoopClosure close_loop(Scene& scene, int image,
                       const ReconstructionOptions& options);

// The share of a loop's correction each image takes (indexed like
// scene.images): 0 for the `old` images, 1 for `image`, and in between the
// harmonic interpolation over the covisibility graph of `image`'s component
// (images linked by the points they share, each link as stiff as its point
// count), the translation part of a pose graph with one correction to
// spread. Along one walk that is linear in walking order; with several
// scouts, whose photos interleave in order of addition, it still follows
// the chain through space that the points make. Images the graph does not
// link to `image` take 0.
std::vector<double> loop_shares(const Scene& scene, const std::vector<int>& old,
                                int image);

}  // namespace arscout::engine
