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
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "arscout/engine/camera.h"
#include "arscout/engine/geo.h"

namespace arscout::engine {

struct ReconstructionOptions {
  int long_side = 1600;       // working resolution (long side, pixels)
  int max_features = 3000;    // Harris corners per image (the strongest)
  int gps_neighbours = 6;     // k nearest captures by GPS to match against
  double gps_radius_m = 150;  // ... within this distance
  int recent_neighbours = 3;  // and the captures added just before
  int visual_neighbours = 4;  // plus registered captures sharing points
  double ratio = 0.8;         // Lowe's ratio test
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
  int local_ba_images = 6;
  // A global adjustment runs when the model has grown by this factor since
  // the last one (COLMAP's rule), and always for small models.
  double global_ba_growth = 1.1;
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

enum class CaptureStatus { kRegistered, kPending, kRejected };
const char* to_string(CaptureStatus status);

struct AddResult {
  std::string id;
  CaptureStatus status = CaptureStatus::kPending;
  std::string reason;  // why not registered (empty when registered)
  int features = 0;
  int matched_pairs = 0;            // verified pairs with other captures
  int pose_inliers = 0;             // 2D-3D inliers of its absolute pose
  double mean_reprojection_px = 0;  // over the whole model, working pixels
  // Other captures that became registered in this increment (e.g. the
  // first two when the model is initialised).
  std::vector<std::string> also_registered;
  bool geo_registered = false;
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
  int camera = 0;  // index into Model::cameras
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

struct Model {
  bool geo_registered = false;
  std::optional<Geodetic> enu_origin;
  std::vector<ModelCamera> cameras;
  std::vector<ModelImage> images;  // registered only, in order of addition
  std::vector<ModelPoint> points;
  double mean_reprojection_px = 0;  // original-photo pixels
};

struct CaptureState {
  std::string id;
  CaptureStatus status = CaptureStatus::kPending;
  std::string reason;
};

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

  // Withdraws a capture: its observations go, and so do the points that
  // only it supported; the model is adjusted again. False if unknown.
  bool remove_capture(const std::string& id);

  Model model() const;
  std::vector<CaptureState> captures() const;
  int registered_count() const;

  // The whole state as bytes (features, matches, poses, points, the ENU
  // origin), so a later process continues without recomputing anything.
  std::string serialize() const;
  // Throws std::runtime_error when the bytes are not a state this version
  // can read.
  static Reconstruction restore(const std::string& bytes,
                                ReconstructionOptions options = {});

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace arscout::engine
