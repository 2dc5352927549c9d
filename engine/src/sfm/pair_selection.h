// Which earlier images a new one is matched with (docs/engine.md,
// "Matching"): its scout's photos just before, the nearest by position (no
// two near duplicates), the nearest in each baseline band, old ones nearby
// for loops, registered ones sharing points with those, and for a photo
// without a fix the best of a visual screen in all four quarter turns.
// Every partner is screened first by a sample of descriptors: never all
// pairs, a bounded set whatever the site's size.
#pragma once

#include <map>
#include <set>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "arscout/engine/options.h"
#include "scene/scene.h"

namespace arscout::engine {

// An image to match against, and the quarter turns that align the new
// image's descriptors with its own.
struct Candidate {
  int image = 0;
  int turns = 0;
};

// Where a capture is believed to be: its place in the model once the model
// is in ENU, else its fix.
Eigen::Vector3d believed_position(const Scene& scene, int index);

// The rows of the strongest `match_features` corners of an image: the only
// ones an increment matches (the weaker ones are the refinement's,
// sfm/densify.cpp).
cv::Mat matched_descriptors(const Scene& scene,
                            const ReconstructionOptions& options, int index);

// The partners of one new image in the scene as it is now. Holds
// references: use it while the scene does not change. Screens run on up to
// options.threads cores; the choice does not depend on the threads.
class PairSelector {
 public:
  PairSelector(const Scene& scene_in, const ReconstructionOptions& options_in)
      : scene(scene_in), options(options_in) {}

  // The partners of image `index` (every earlier image is a candidate),
  // each with the quarter turns that align the new image's descriptors
  // with the partner's.
  std::vector<Candidate> neighbours(int index) const;

 private:
  bool near_duplicate(int a, int b) const;
  double depth_of(int index) const;
  std::vector<std::pair<double, int>> by_distance(int index) const;
  std::set<int> spatial_neighbours(int index, std::set<int> chosen) const;
  std::vector<int> loop_candidates(
      int index, const std::vector<std::pair<double, int>>& ranked,
      const std::set<int>& chosen) const;
  std::vector<int> covisible_with(const std::set<int>& images) const;
  int overlap(int index, int other) const;
  std::vector<int> overlaps(int index, const std::vector<int>& others) const;
  std::pair<int, int> best_rotation(int index, int other) const;
  std::vector<Candidate> visual_screen(int index,
                                       const std::set<int>& skip) const;

  const Scene& scene;
  const ReconstructionOptions& options;
  // Median depths of the images this selection has weighed: near_duplicate
  // asks for a candidate's once per partner already chosen, and each costs
  // a pass over its points.
  mutable std::map<int, double> depth_memo;
};

}  // namespace arscout::engine
