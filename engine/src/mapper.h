// The incremental mapping steps on a Scene whose images are already matched:
// initialization from the best-conditioned pair, registration of further
// images by absolute pose, triangulation, bundle adjustment (local, and
// global when the model has grown) and geo-registration to ENU.
#pragma once

#include <random>
#include <set>
#include <vector>

#include "arscout/engine/reconstruction.h"
#include "bundle_adjuster.h"
#include "estimators.h"
#include "scene.h"

namespace arscout::engine {

class IncrementalMapper {
 public:
  IncrementalMapper(Scene& scene, const ReconstructionOptions& options,
                    StageTimings& timings);

  // Registers every image it can (initializing the model first when it has
  // none); returns the newly registered images in order of registration.
  std::vector<int> update();
  // After a withdrawal: re-initializes when too little is left, else
  // adjusts the whole model again.
  void repair_after_removal();
  // Mean reprojection error over all observations, working pixels.
  double mean_reprojection_px() const;
  // 2D-3D correspondences an unregistered image has (keypoint, point).
  std::vector<std::pair<int, int64_t>> correspondences(int image) const;

 private:
  int next_image(const std::set<int>& failed, size_t* count) const;
  bool initialize();
  bool try_initial_pair(int a, int b, const ImagePair& pair);
  bool register_image(int image);
  bool register_from_pair(int image);
  void triangulate_image(int image);
  void extend_track(int64_t point, Observation obs);
  void merge_tracks(int64_t a, int64_t b);
  bool triangulate_pair_match(Observation first, Observation second);
  void adjust_local(int image);
  void adjust_global();
  void filter_points(const std::vector<int>& images);
  void geo_register();
  void transform_model(const Similarity& sim);
  BundleOptions bundle_options(int max_iterations) const;
  void align_to_priors(const BundleOptions& ba);
  Eigen::Vector3d model_up() const;
  void level(Similarity& sim, const std::vector<Eigen::Vector3d>& fixes,
             const std::vector<int>& inliers) const;
  void reset_model();
  double threshold_normalized(int image) const;
  std::vector<int> covisible_images(int image, int limit) const;

  Scene& scene_;
  const ReconstructionOptions& options_;
  StageTimings& timings_;
};

}  // namespace arscout::engine
