// The incremental mapping steps on a Scene whose images are already matched:
// initialization from the best-conditioned pair, registration of further
// images by absolute pose, triangulation, bundle adjustment (local, and
// global when the model has grown) and geo-registration to ENU.
//
// A scene holds components: separately reconstructed parts of one site
// (a walk with a break, scouts starting in different places). Photos that
// no component reaches start one of their own once the first is in ENU,
// each is placed in ENU through its own photos' fixes, and a photo that
// links two of them merges them (sfm/components.cpp,
// sfm/component_merge.cpp, docs/engine.md).
#pragma once

#include <functional>
#include <map>
#include <optional>
#include <random>
#include <set>
#include <vector>

#include "arscout/engine/model.h"
#include "arscout/engine/options.h"
#include "estimators/bundle_adjuster.h"
#include "estimators/estimators.h"
#include "scene/scene.h"

namespace arscout::engine {

class IncrementalMapper {
 public:
  IncrementalMapper(Scene& scene, const ReconstructionOptions& options,
                    StageTimings& timings);

  // Registers every image it can (initializing the model first when it has
  // none); returns the newly registered images in order of registration.
  std::vector<int> update();
  // While set, update() leaves the inline global adjustment of a small
  // model to a later call (CaptureInput::more_follow); the rule that makes
  // it due counts from the last one, so the next call without it runs it.
  void defer_global_adjustment(bool defer) { defer_global_ = defer; }
  // After a withdrawal: re-initializes when too little is left, else
  // adjusts the whole model again.
  void repair_after_removal();
  // The global adjustment left out of update() for large models (see
  // Reconstruction::refine).
  RefineResult refine(const std::function<bool()>& stop);
  bool refinement_due() const;
  // Due, and a merge or a loop closure moved cameras since the refinement
  // last settled (Reconstruction::refinement_urgent).
  bool refinement_urgent() const;
  // Loops closed by this mapper's update() calls.
  int loops_closed() const { return loops_closed_; }
  // Global adjustments this mapper ran inside update().
  int global_adjustments() const { return global_adjustments_; }
  // Small components that stopped growing, retired by update() calls.
  int components_retired() const { return components_retired_; }
  // Mean reprojection error over all observations, working pixels.
  // Merges the components that registered photos link (sfm/
  // component_merge.cpp); returns the merges made.
  int sweep_merges(const std::function<bool()>& stop);
  // Joins the verified matches whose two keypoints the model holds as two
  // points, or one as none, wherever one position explains both (as COLMAP
  // completes and merges tracks after a global adjustment); refine() runs
  // it after each round. Returns the matches joined. `stop` (may be empty)
  // is asked every 64 pairs; what was joined before it said so stays.
  int join_tracks(const std::function<bool()>& stop);
  // The verified matches of each loose pair (registered, one component, at
  // least 15 matches, fewer than one in five on a point both hold: a weak
  // link of a walk that a ring of merges closed untied) linked into tracks
  // (two points merged, a track extended, a new point) within
  // max_reprojection_px, else within ten times it: those are `strained`,
  // the model's poses there disagree with the pair (sfm/loose_pairs.cpp).
  // A pair found strained in two rounds is not tried again.
  // refine() runs it before its adjustment. `stop` (may be empty) is
  // asked every 64 pairs.
  struct LooseTies {
    int linked = 0;
    int strained = 0;
  };
  LooseTies tie_loose_pairs(const std::function<bool()>& stop);
  // The weaker corners the increments leave out (past
  // ReconstructionOptions::match_features) matched along the epipolar lines
  // of each registered pair not done yet, and the matches linked into
  // tracks (sfm/densify.cpp); refine() runs it before its adjustment.
  // Returns the matches that joined a track or made a point; stops early
  // when `stop` says so.
  int densify_tracks(const std::function<bool()>& stop);
  // Components merged by this mapper's update() calls.
  int components_merged() const { return components_merged_; }
  // 2D-3D correspondences an image has with one component's points
  // (keypoint, point).
  std::vector<std::pair<int, int64_t>> correspondences(int image,
                                                       int component) const;
  // The same for every component its matches reach, by component.
  std::map<int, std::vector<std::pair<int, int64_t>>>
  correspondences_by_component(int image) const;

 private:
  int next_image(const std::set<int>& failed, size_t* count, int* component,
                 int only = -1) const;
  bool initialize();
  std::vector<std::pair<int, int>> initial_pairs(
      const std::function<bool(int, int)>& usable) const;
  bool try_initial_pair(int a, int b, const ImagePair& pair);
  size_t place_pair(int a, int b, const ImagePair& pair, int component);
  // Components (sfm/components.cpp, sfm/component_merge.cpp).
  bool start_component(std::vector<int>& registered);
  bool try_component_pair(int a, int b, std::vector<int>& registered);
  int register_third(int component);
  void dissolve_component(int component);
  void retire_stalled_components();
  void merge_through(int index);
  bool merge_components(int a, int b, int via);
  std::map<int, Eigen::Vector3d> bridge_points(int via, const SceneImage& posed,
                                               int component) const;
  void common_positions(int keep, int gone, int via,
                        std::vector<Eigen::Vector3d>* in_keep,
                        std::vector<Eigen::Vector3d>* in_gone,
                        std::vector<std::pair<int64_t, int64_t>>* same) const;
  std::optional<Similarity> point_similarity(
      int keep, int gone, int via,
      std::vector<std::pair<int64_t, int64_t>>* agreed) const;
  struct Hinge {
    int image = 0;
    Eigen::Quaterniond keep_q;
    Eigen::Vector3d keep_centre;
    Eigen::Quaterniond gone_q;
    Eigen::Vector3d gone_centre;
  };
  std::vector<Hinge> hinges(int keep, int gone) const;
  std::optional<Similarity> hinge_similarity(
      const std::vector<Hinge>& hinges) const;
  std::optional<AbsolutePose> pose_in(int index, int component) const;
  // Verified pairs of registered photos, one in component a and one in b,
  // most matches first (sfm/pair_bridge.cpp).
  std::vector<std::pair<int, int>> pairs_across(int a, int b) const;
  std::optional<Similarity> similarity_through_pair(
      const std::pair<int, int>& key) const;
  std::optional<Similarity> similarity_by_baseline(
      const std::pair<int, int>& key) const;
  std::optional<Similarity> similarity_by_rotation(
      const std::pair<int, int>& key) const;
  bool bridge_reprojects(const std::pair<int, int>& key,
                         const Similarity& sim) const;
  std::optional<Eigen::Vector3d> centre_at_rotation(
      const std::pair<int, int>& key, const Eigen::Matrix3d& R) const;
  // gone's frame to keep's through the first pair across them that fixes
  // it (the seam's photos include every pair across anyway).
  std::optional<Similarity> pair_similarity(int keep, int gone) const;
  void weld_seam(int component, const std::vector<int>& bridges,
                 const std::vector<std::pair<int64_t, int64_t>>& same_points);
  void register_by_points(std::vector<int>& registered, int limit,
                          const std::function<bool()>& stop);
  void extend_model(int index);
  bool catch_up(const std::function<bool()>& stop, RefineResult& result);
  bool register_image(int index, int component);
  bool pose_loose(int index) const;
  bool register_from_pair(int index, int component);
  void second_opinion(int index);
  struct PairPose {
    Eigen::Quaterniond q;
    Eigen::Vector3d centre;
    std::vector<std::pair<int, int64_t>> agreeing;
  };
  std::optional<PairPose> pair_pose(
      int index, const std::vector<std::pair<int, int64_t>>& corr,
      int component) const;
  static bool pair_pose_holds(const PairPose& pose, size_t correspondences);
  void set_pose(int index, const Eigen::Quaterniond& q,
                const Eigen::Vector3d& centre,
                const std::vector<std::pair<int, int64_t>>& agreeing,
                int component);
  std::optional<double> baseline_length(
      int index, const Eigen::Matrix3d& R, const Eigen::Vector3d& C0,
      const Eigen::Vector3d& direction,
      const std::vector<std::pair<int, int64_t>>& corr) const;
  std::optional<Eigen::Matrix3d> turn_rotation(int index, int other,
                                               const ImagePair& pair) const;
  std::vector<std::pair<int, int64_t>> agreeing_matches(
      int index, const Eigen::Quaterniond& q, const Eigen::Vector3d& centre,
      const std::vector<std::pair<int, int64_t>>& corr) const;
  void triangulate_image(int index);
  void refine_keypoints(int index);
  // The registered images' centres in image order, and the farthest one
  // moved since `before` (taken with no registration between the two).
  std::vector<Eigen::Vector3d> registered_centres() const;
  double largest_move(const std::vector<Eigen::Vector3d>& before) const;
  std::optional<Observation> track_reference(int64_t point, int image) const;
  const uchar* patch_of(const Observation& obs) const;
  std::optional<Eigen::Vector2d> align_through_neighbour(
      int64_t point, const Observation& reference,
      const Observation& target) const;
  // The track operations within max_reprojection_px, or `max_px`.
  void extend_track(int64_t point_id, Observation obs);
  void extend_track(int64_t point_id, Observation obs, double max_px);
  void merge_tracks(int64_t a, int64_t b);
  void merge_tracks(int64_t a, int64_t b, double max_px);
  bool triangulate_pair_match(Observation first, Observation second,
                              double max_px);
  void link_match(Observation first, Observation second);
  // True when the two keypoints then hold one point.
  bool link_match(Observation first, Observation second, double max_px);
  int densify_pair(const std::pair<int, int>& key, ImagePair& pair);
  bool align_to_track(Observation obs);
  // Within max_reprojection_px, or `max_px`.
  std::optional<Eigen::Vector3d> triangulated(const SceneImage& a,
                                              Observation first,
                                              const SceneImage& b,
                                              Observation second) const;
  std::optional<Eigen::Vector3d> triangulated(const SceneImage& a,
                                              Observation first,
                                              const SceneImage& b,
                                              Observation second,
                                              double max_px) const;
  void close_loops(int index);
  // Calls `visit` for each pair of registered images of one component,
  // asking `stop` (may be empty) every 64 pairs; it ends when that says so.
  void visit_linked_pairs(const std::function<bool()>& stop,
                          const std::function<void(const std::pair<int, int>&,
                                                   const ImagePair&)>& visit);
  BundleOptions refinement_options(const std::function<bool()>& stop,
                                   bool strained);
  std::vector<int> key_views() const;
  void adjust_pose(int index);
  void adjust_local(int index);
  bool near_duplicate_view(int index, const std::vector<int>& covisible) const;
  void adjust_global();
  bool global_inline() const;
  bool inline_global_due() const;
  void filter_points(const std::vector<int>& images);
  bool geo_register(int component, bool placed);
  std::optional<Similarity> first_placement(int component) const;
  // `start`: the component's first_placement (the fit's starting point).
  std::optional<Similarity> fit_to_priors(
      const BundleOptions& ba, int component,
      const std::optional<Similarity>& start) const;
  void transform_model(const Similarity& sim, int component);
  BundleOptions bundle_options(int max_iterations) const;
  void align_to_priors(const BundleOptions& ba);
  Eigen::Vector3d model_up(int component) const;
  void level(Similarity& sim, const std::vector<Eigen::Vector3d>& fixes,
             const std::vector<int>& inliers, int component) const;
  void reset_model();
  double threshold_normalized(int image) const;
  std::vector<int> covisible_images(int index, int limit) const;

  Scene& scene_;
  const ReconstructionOptions& options_;
  StageTimings& timings_;
  int loops_closed_ = 0;
  int components_retired_ = 0;
  bool defer_global_ = false;
  int global_adjustments_ = 0;
  int components_merged_ = 0;
};

}  // namespace arscout::engine
