// The scene's vocabulary: a site's model as the engine publishes it
// (cameras, registered images, points, components), the capture statuses,
// and what the pipeline's calls take and report (a capture to add, the
// results of adding, refining and absorbing). The bottom of the engine's
// layers: everything above may speak it.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "arscout/documents/capture_status.h"
#include "arscout/engine/camera.h"
#include "arscout/engine/geo.h"

namespace arscout::engine {

// What to add: the encoded photo (JPEG or PNG), its camera, and a fix.
struct CaptureInput {
  std::string id;
  std::string image_bytes;
  // When absent, a guess from the image size is used (and refined).
  std::optional<CameraIntrinsics> camera;
  // Captures naming the same camera share (and jointly refine) intrinsics.
  std::string camera_id;
  std::optional<GeoFix> gps;
  // Who took it: a photo is matched with its own scout's recent photos
  // (its walk), not with whoever uploaded just before. "" when unknown.
  std::string scout;
  // More captures follow in the same increment (the service folds those
  // queued meanwhile): a global adjustment of a small model that falls due
  // now waits for the increment's last capture, so an increment runs it
  // once, not after every other photo (docs/engine.md, "Bounded
  // increments").
  bool more_follow = false;
};

struct StageTimings {
  double decode_s = 0;
  double undistort_s = 0;
  double features_s = 0;
  double matching_s = 0;
  double pose_s = 0;
  double triangulation_s = 0;
  double bundle_adjustment_s = 0;
  double total_s = 0;
};

// The one list of capture statuses (documents/capture_status.h): a
// capture the engine holds is registered, pending or rejected.
using documents::CaptureStatus;

struct AddResult {
  std::string id;
  CaptureStatus status = CaptureStatus::kPending;
  std::string reason;  // why not registered (empty when registered)
  int features = 0;
  int matched_pairs = 0;  // verified pairs with other captures
  int pose_inliers = 0;   // 2D-3D inliers of its absolute pose
  // Other captures that became registered in this increment (e.g. the
  // first two when the model is initialised).
  std::vector<std::string> also_registered;
  bool geo_registered = false;
  // Loops this capture closed: it matched old captures of the same place
  // whose points had drifted from its own (docs/engine.md).
  int loops_closed = 0;
  // The component it registered in (-1 when not registered), and how many
  // merges of two components this increment made.
  int component = -1;
  int components_merged = 0;
  // Small components that stopped growing, retired by this increment
  // (ReconstructionOptions::retire_component_below).
  int components_retired = 0;
  // Global adjustments this call ran inside the increment (a small model's
  // periodic one, or after a loop closure); 0 when deferred (more_follow).
  int global_adjustments = 0;
  StageTimings timings;
};

// The model, as read by writers and the service. Poses are world-to-camera
// (R as a unit quaternion w, x, y, z, and t), OpenCV camera axes (COLMAP's
// convention); the world frame is the site's ENU frame once geo_registered,
// else an arbitrary local frame.
struct ModelCamera {
  std::string id;
  CameraIntrinsics intrinsics;  // refined, original-photo pixels
};

struct ModelImage {
  std::string id;
  int camera = 0;     // index into Model::cameras
  int component = 0;  // its component's id (ModelComponent::id)
  std::array<double, 4> qvec{1, 0, 0, 0};
  std::array<double, 3> tvec{0, 0, 0};
  std::array<double, 3> centre{0, 0, 0};
  std::optional<Geodetic> geodetic;  // when geo_registered
  // Keypoints in original-photo pixels (OpenCV convention) and the point
  // each one observes (-1 for none).
  std::vector<std::array<double, 2>> keypoints;
  std::vector<int64_t> point_ids;
};

struct ModelPoint {
  int64_t id = 0;
  std::array<double, 3> xyz{0, 0, 0};
  std::array<uint8_t, 3> rgb{0, 0, 0};
  double error_px = 0;  // mean reprojection error, original-photo pixels
  // (index into Model::images, keypoint index)
  std::vector<std::pair<int, int>> track;
};

// A separately reconstructed part of the model. Ids are stable while the
// component lives; when two merge, the larger keeps its id.
struct ModelComponent {
  int id = 0;
  int images = 0;
  int points = 0;
};

struct Model {
  bool geo_registered = false;  // every component is in the site's ENU frame
  std::optional<Geodetic> enu_origin;
  std::vector<ModelCamera> cameras;
  std::vector<ModelImage> images;  // registered only, in order of addition
  std::vector<ModelPoint> points;
  // Largest first (by images, then lowest id).
  std::vector<ModelComponent> components;
  double mean_reprojection_px = 0;  // original-photo pixels
};

// What one call of Reconstruction::refine did.
struct RefineResult {
  bool ran = false;        // false: nothing to refine
  bool converged = false;  // false: stopped early (progress is kept)
  int iterations = 0;
  int images = 0;
  double seconds = 0;
  // The keypoint deviation the adjustment weighed by and its Cauchy scale,
  // pixels (docs/engine.md, "The loss scale follows the keypoints").
  double pixel_sigma = 0;
  double loss_scale_px = 0;
  // The farthest the adjustment moved a camera centre in this call (after
  // the model was placed on its fixes, which moves it as a whole), in the
  // model's units.
  double largest_move = 0;
  // Matches the round joined into tracks after its adjustment (two points
  // of one place merged, or an observation added); when many, another
  // round is due.
  int tracks_joined = 0;
  // Weaker corners (past ReconstructionOptions::match_features) the round
  // matched along registered pairs' epipolar lines and linked into tracks
  // before its adjustment (docs/engine.md, "How many corners").
  int corners_matched = 0;
  // Matches of loose pairs the round linked into tracks before its
  // adjustment (a walk's weak link closed untied by a ring of merges), and
  // of those the strained ones, pixels off the model's poses there
  // (docs/engine.md, "Weak links").
  int loose_links = 0;
  int strained_links = 0;
  // Waiting captures this call registered (ids, in order); when any, the
  // call did only that, and the global adjustment is due next.
  std::vector<std::string> registered;
  // Components this call merged (the photos that link them came in before
  // the second grew to meet them); when any, the call did only that.
  int components_merged = 0;
};

// What Reconstruction::absorb did.
struct AbsorbResult {
  int captures = 0;      // taken in
  int pairs_across = 0;  // verified pairs between the two scenes' photos
  // Captures registered on the links (waiting ones of either side).
  std::vector<std::string> registered;
  int components_merged = 0;
};

struct CaptureState {
  std::string id;
  CaptureStatus status = CaptureStatus::kPending;
  std::string reason;
  int component = -1;  // when registered
};

}  // namespace arscout::engine
