// Incremental structure from motion for one site (the paper's sections
// 3.1-3.3): each capture is added on its own and updates the model at once,
// metric and in the site's ENU frame as soon as three registered captures
// carry GPS.
//
//   Reconstruction site(options);
//   AddResult r = site.add_capture({"c-1", jpeg_bytes, camera, "cam-a", fix});
//   Model m = site.model();
//   std::string state = site.serialize();   // ... later, in a new process:
//   Reconstruction resumed = Reconstruction::restore(state, options);
//
// A site's model may be made of several components (separately
// reconstructed parts: a walk with a break, scouts starting in different
// places). Photos that reach no component start one of their own, each is
// placed in ENU through its own fixes, and a photo that matches two merges
// them (docs/engine.md, "Components").
//
// Per capture: decode at the working resolution, undistort through the
// camera's look-up table, Harris corners with SIFT descriptors, matching
// against the capture's GPS neighbours and recent captures (never all
// pairs), geometric verification; with 3 captures the initial pair by the
// 5-point relative pose, then absolute pose (P3P in RANSAC) for each capture,
// triangulation, local bundle adjustment and a periodic global one with GPS
// priors, and a robust similarity to ENU.
//
// Not thread-safe: one site is driven by one thread at a time. Work inside a
// call uses up to `threads` cores.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "arscout/documents/capture_status.h"
#include "arscout/engine/camera.h"
#include "arscout/engine/geo.h"

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

// What add_capture does to a photo before it touches the model: decoding
// at the working resolution, undistortion, features (the slowest part of a
// photo that does not depend on the model). prepare_capture is a pure
// function of the capture and the options and touches no Reconstruction, so
// a service runs it on another thread while the site's model is busy with
// earlier photos, and the photo's increment starts with its features ready.
// Opaque; copies share one immutable result.
class PreparedCapture {
 public:
  struct Impl;
  PreparedCapture();
  ~PreparedCapture();
  PreparedCapture(const PreparedCapture&);
  PreparedCapture& operator=(const PreparedCapture&);
  const std::string& capture_id() const;  // "" for a default-made one
  // Decode, undistortion and features, as add_capture would time them.
  StageTimings timings() const;

 private:
  friend PreparedCapture prepare_capture(const CaptureInput&,
                                         const ReconstructionOptions&);
  friend class Reconstruction;
  std::shared_ptr<const Impl> impl_;
};

// Throws std::invalid_argument as add_capture does for a photo that cannot
// be decoded or an invalid camera. `capture.image_bytes` is read, not kept.
PreparedCapture prepare_capture(const CaptureInput& capture,
                                const ReconstructionOptions& options);

class Reconstruction {
 public:
  explicit Reconstruction(ReconstructionOptions options = {});
  ~Reconstruction();
  Reconstruction(Reconstruction&&) noexcept;
  Reconstruction& operator=(Reconstruction&&) noexcept;

  // Adds one capture and updates the model. Throws std::invalid_argument
  // for a duplicate id, an image that cannot be decoded or an invalid
  // camera; the model is then unchanged.
  AddResult add_capture(const CaptureInput& capture);
  // The same with the photo prepared ahead (prepare_capture on the same
  // capture with this site's options): its features are used when they
  // were made for the camera this site holds for the capture (else the
  // photo is prepared again here), and `capture.image_bytes` is then not
  // read. The result is the same as add_capture(capture)'s; its timings
  // count only this call's stages.
  AddResult add_capture(const CaptureInput& capture,
                        const PreparedCapture& prepared);

  // Takes another site's reconstruction in (two sites that grew together,
  // docs/engine.md "Sites that grow together"): its captures, their
  // features, matches, poses and points join this one, moved from its ENU
  // frame into this one's, its components kept apart (renumbered after
  // this one's) until photos link them; the photos of each side nearest the
  // other are matched across at once (a bounded number), and the
  // components they link merge. `other` is left empty. Throws
  // std::invalid_argument, changing nothing, when either model has
  // registered captures but is not in ENU, or a capture is in both.
  AbsorbResult absorb(Reconstruction&& other);

  // Withdraws a capture: its observations go, and so do the points that
  // only it supported; the model is adjusted again. False if unknown.
  bool remove_capture(const std::string& id);

  // The global adjustment that add_capture leaves out once the model has
  // grown past `inline_global_ba_images`: all poses, points and refinable
  // intrinsics, with the GPS priors. `stop` is asked after every solver
  // iteration; when it says true the adjustment ends there and keeps the
  // progress made so far (each accepted iteration lowers the cost), so a
  // caller can run it between captures and give way to a new one. Does
  // nothing when nothing was registered since the last complete run.
  // Components that the photos registered since the last call link come
  // first: refine() merges them and returns. Then the captures that
  // add_capture left waiting beyond `max_registrations_per_update`:
  // refine() registers them, asking `stop` after each, and returns; the
  // adjustment is the next call's.
  RefineResult refine(const std::function<bool()>& stop = {});
  // True when refine() has work to do.
  bool refinement_due() const;
  // True when refine() has work and a merge of components or a loop
  // closure moved cameras since it last settled (a round met its tolerance,
  // or the bounded number of rounds on one model ran): the cameras may be
  // off by decimetres across the seam, and work that uses the poses (the
  // dense phase) should wait for the refinement.
  bool refinement_urgent() const;

  Model model() const;
  // The mean reprojection error over the whole model, working pixels (a
  // pass over every observation: for progress lines, not per increment).
  double mean_reprojection_px() const;
  std::vector<CaptureState> captures() const;
  int registered_count() const;

  // The whole state as bytes (features, matches, poses, points, the ENU
  // origin), so a later process continues without recomputing anything.
  // With `features_apart`, every capture's features (keypoints, descriptors
  // and colours: fixed once extracted, and most of the bytes) are left out:
  // a store keeps capture_features() of each capture once, and the state it
  // writes per increment stays a fraction of the site's size.
  std::string serialize(bool features_apart = false) const;
  // The captures whose features serialize(true) leaves out.
  std::vector<std::string> captures_with_features() const;
  // Whether `capture` is one of them (no list built: asked per new capture
  // of every increment).
  bool has_features(const std::string& capture) const;
  // One such capture's features as bytes; throws std::invalid_argument for
  // a capture without features here.
  std::string capture_features(const std::string& capture) const;
  // Throws std::runtime_error when the bytes are not a state this version
  // can read, or when features left out are not given by `features` (asked
  // by capture id for exactly those) or are not that capture's.
  static Reconstruction restore(
      const std::string& bytes, ReconstructionOptions options = {},
      const std::function<std::string(const std::string&)>& features = {});

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace arscout::engine
