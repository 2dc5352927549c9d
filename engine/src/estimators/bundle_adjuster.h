// Bundle adjustment in Ceres: reprojection error with a robust loss,
// intrinsics refinement shared per camera, and GPS priors on camera centres
// weighted by each fix's horizontal and vertical accuracy (the paper's
// section 3.3). The only translation unit that includes Ceres.
#pragma once

#include <functional>
#include <optional>
#include <set>
#include <vector>

#include "estimators/estimators.h"
#include "scene/scene.h"

namespace arscout::engine {

struct BundleOptions {
  bool gps_priors = false;       // scene is in ENU and fixes pull the centres
  double upright_sigma_deg = 0;  // > 0: camera x axes held horizontal (ENU)
  double loss_scale_px = 1.0;    // Cauchy loss scale
  // > 0: the Cauchy scale is this many keypoint deviations (the pixel_sigma
  // in use) instead of loss_scale_px. A long walk's keypoints are a
  // mixture: most good to a tenth of a pixel, some several times worse; a
  // loss that keeps full weight up to 1 px lets the worse ones bend the
  // model (docs/engine.md, "The loss scale follows the keypoints").
  double loss_scale_sigmas = 0;
  // Standard deviation of a keypoint's position (working pixels): the
  // reprojection errors are weighted by 1 / sigma^2 against the GPS and
  // upright priors, which are in units of their own deviations. With the
  // default of 1 px the priors pull as hard as if features were 1 px off;
  // features good to a third of that would let the fixes' noise bend the
  // model (docs/engine.md, "Weighting features against fixes"). 0: the
  // a-posteriori estimate from the problem's own residuals before solving
  // (their median, as for a 2D Gaussian, corrected for the points' degrees
  // of freedom), within [0.1, 1] px.
  double pixel_sigma = 1.0;
  int max_iterations = 50;
  // Ceres' relative decrease of the cost that ends the solve.
  double function_tolerance = 1e-6;
  int threads = 1;
  // Local adjustments only: of the images that observe the free images'
  // points without being free, the `max_fixed_images` sharing the most
  // points are held fixed and the others left out; each point keeps its
  // free observations and fixed ones up to `max_track_observations` in all
  // (0: no limit). This bounds the problem whatever the model's size.
  int max_fixed_images = 0;
  int max_track_observations = 0;
  // Local adjustments only, > 0: observations of keypoints at or past this
  // index (the weaker corners, which the refinement adds: sfm/densify.cpp)
  // are left out, so a window costs what the increments' own corners do.
  int strong_keypoints = 0;
  // Global adjustments only: when set, the problem holds these registered
  // images alone (the others' observations are left out, their poses
  // untouched), and points with more than `max_track_observations` of them
  // keep that many, spread evenly along the track.
  std::set<int> global_images;
  // Local adjustments only: points held where they are, so only the free
  // poses move (motion-only adjustment).
  bool points_fixed = false;
  // Asked while the problem is built and after every iteration; true ends
  // the adjustment there, keeping the progress made (the last accepted
  // iterate; nothing moved when it ends before the first iteration,
  // BundleReport::iterations 0).
  std::function<bool()> stop;
};

struct BundleReport {
  int iterations = 0;
  // pixel_sigma * sqrt(2 cost / residuals) of the solver's cost, which
  // includes the robust loss and the priors: an RMS in pixels only when
  // residuals are small (well below the loss scale), as after convergence.
  double initial_rms_px = 0;
  double final_rms_px = 0;
  int images = 0;
  int points = 0;
  bool stopped = false;      // ended early by BundleOptions::stop
  bool converged = false;    // by the tolerances, not the iteration cap
  double pixel_sigma = 1;    // the keypoint deviation weighted by, pixels
  double loss_scale_px = 1;  // the Cauchy scale used, pixels
};

// One observation's reprojection residual in working pixels, as the
// adjustment minimizes it: `point` through the pose (q in Eigen's storage
// order x, y, z, w, normalized as applied; t) and the intrinsics k = fx, fy,
// cx, cy, k1, k2 (fy follows fx by `aspect`, k[1] is not read), minus
// `observed`. With `jacobians`, each non-null entry receives the row-major
// derivative with respect to q (2 x 4), t (2 x 3), point (2 x 3) or k
// (2 x 6), as ceres::CostFunction::Evaluate fills them. False never (the
// signature is Ceres'); a point at depth 0 gives non-finite values.
bool evaluate_reprojection(const double* q, const double* t,
                           const double* point, const double* k,
                           const Eigen::Vector2d& observed, double aspect,
                           double* residual, double** jacobians);

// Adjusts the poses of `free_images` and every point they observe; other
// registered images observing those points are held constant. With
// `global`, all registered images and points are free (free_images is
// ignored). Cameras with SceneCamera::refine set refine their focal length
// and radial terms in a global adjustment only. Without GPS priors the
// gauge is held by Scene::reference_image (and the scale by one coordinate
// of Scene::scale_image in a global adjustment).
// The similarity that best moves the registered cameras onto their GPS
// fixes (weighted per axis, as in the adjustment) while keeping them level
// (the upright prior): the directions in which reprojection errors do not
// constrain the model, solved on their own so that the adjustment starts
// at their optimum. Over the images of one component (each is placed in
// ENU on its own until components merge). nullopt with fewer than 3 fixes.
// A local solve from `start`: from a model turned more than a right angle
// from its fixes it shrinks the model instead of turning it, so start it
// near the answer (the fixes' robust placement, IncrementalMapper::
// fit_to_priors). Its scale stays within a factor of 100 of start's.
std::optional<Similarity> fit_model_to_priors(const Scene& scene,
                                              const BundleOptions& options,
                                              int component,
                                              const Similarity& start = {});

// Refines a relative pose (x2 = R x1 + t, |t| = 1) on its inlier
// correspondences (normalized coordinates) by minimizing the Sampson
// distance: RANSAC's best sample is only as good as its five points.
void refine_relative_pose(const std::vector<Eigen::Vector2d>& x1,
                          const std::vector<Eigen::Vector2d>& x2,
                          const std::vector<int>& inliers, Eigen::Matrix3d* R,
                          Eigen::Vector3d* t);

BundleReport adjust_bundle(Scene& scene, const std::vector<int>& free_images,
                           bool global, const BundleOptions& options);

}  // namespace arscout::engine
