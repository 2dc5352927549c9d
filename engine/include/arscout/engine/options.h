// How a site is reconstructed: the options of the whole pipeline, from the
// working resolution and the features to matching, registration, the
// adjustments and components (docs/engine.md). One struct for the engine's
// layers, from the scene up.
#pragma once

#include <string>

namespace arscout::engine {

struct ReconstructionOptions {
  int long_side = 1600;     // working resolution (long side, pixels)
  int max_features = 4500;  // Harris corners per image (the strongest)
  // Of those, the strongest `match_features` are what an increment matches
  // and registers by; any weaker rest (max_features above this) is matched
  // along the epipolar lines of registered pairs by the refinement, off the
  // latency path, to stiffen the model (docs/engine.md, "How many
  // corners").
  int match_features = 3000;
  int gps_neighbours = 6;     // k nearest captures by GPS to match against
  double gps_radius_m = 150;  // ... within this distance
  int recent_neighbours = 3;  // and its scout's captures added just before
  int visual_neighbours = 4;  // plus registered captures sharing points
  // Partners for parallax: the nearest capture in each distance band
  // [b, 2b) for b = baseline_min_m, 2 baseline_min_m, ... (this many bands),
  // so that a burst from one spot still has a pair to triangulate with.
  int baseline_neighbours = 4;
  double baseline_min_m = 0.5;
  // Partners for loops: of the 8 captures nearest by position among those
  // added before the last `loop_min_age`, the ones a cheap visual screen
  // ranks best.
  int loop_neighbours = 2;
  int loop_min_age = 30;
  double ratio = 0.8;                // Lowe's ratio test
  double max_reprojection_px = 4.0;  // at the working resolution
  int min_pair_inliers = 20;
  int min_pose_inliers = 15;
  double min_triangulation_angle_deg = 0.75;
  // "auto": refine focal length and radial distortion of cameras whose
  // intrinsics were not calibrated; "on": refine all; "off": keep as given.
  std::string refine_intrinsics = "auto";
  // Scouts hold the camera level: once the model is in ENU, each camera's
  // x axis (image right) is held horizontal with this standard deviation,
  // which keeps the vertical GPS noise from tilting the model. Portrait
  // photos are outliers to a robust loss. 0 turns the prior off.
  double upright_sigma_deg = 2.0;
  // Local adjustment after each registration: the new capture and its most
  // covisible registered captures are free; of the others observing the
  // same points, the most covisible are held fixed, and each point keeps at
  // most `local_ba_track` observations. Bounded whatever the site's size.
  int local_ba_images = 6;
  int local_ba_fixed = 20;
  int local_ba_track = 10;
  // While the model has at most this many registered captures, a global
  // adjustment runs inside add_capture whenever the model has grown by
  // `global_ba_growth` since the last one (COLMAP's rule). Beyond it the
  // global adjustment is left to refine(), off the latency path.
  int inline_global_ba_images = 30;
  double global_ba_growth = 1.1;
  // Captures one add_capture registers at most by absolute pose (the
  // initial model's aside): the new one and those waiting that its points
  // let register, most 2D-3D matches first. A photo that closes a loop can free
  // a long wait (on the 150-photo block walk, 80 photos behind a gap in the
  // walk); the rest of them are registered by refine(), between captures, so
  // that no increment costs more than this many registrations. 0: no limit.
  int max_registrations_per_update = 8;
  // Photos that reach no component start one of their own once the model
  // is in ENU (docs/engine.md, "Components"); false keeps one chain, and
  // such photos wait until it reaches them (COLMAP's multiple_models).
  bool multiple_models = true;
  // A component with fewer photos than `retire_component_below` that has
  // not grown while the site took `retire_component_after` photos is
  // retired: its photos wait again, for whichever component grows to reach
  // them (docs/engine.md, "Components"). Never the largest.
  int retire_component_below = 5;
  int retire_component_after = 50;
  int threads = 2;
  // Fixed seeds and single-threaded solvers: the same inputs give
  // bit-identical output, also across serialize/restore.
  bool deterministic = false;
};

}  // namespace arscout::engine
