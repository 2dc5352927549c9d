// The engine's state for one site: everything Reconstruction::serialize
// writes. Images are kept in order of addition and never renumbered (a
// withdrawn one stays as a tombstone), so indices in tracks and pairs stay
// valid.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "arscout/engine/camera.h"
#include "arscout/engine/geo.h"
#include "arscout/engine/model.h"
#include "arscout/engine/options.h"

namespace arscout::engine {

// Intrinsics at the working resolution after the look-up-table
// undistortion: a pinhole plus a residual radial term (k1, k2) that bundle
// adjustment may refine. params = {fx, fy, cx, cy, k1, k2}.
struct SceneCamera {
  std::string id;
  CameraIntrinsics original;  // as given, original-photo pixels
  double scale = 1;           // working / original
  std::array<double, 6> params{};
  bool refine = false;
};

struct Observation {
  int image = 0;
  int keypoint = 0;
  bool operator==(const Observation&) const = default;
};

struct ScenePoint {
  Eigen::Vector3d xyz = Eigen::Vector3d::Zero();
  std::array<uint8_t, 3> rgb{0, 0, 0};
  std::vector<Observation> track;
};

struct SceneImage {
  std::string id;
  std::string scout;  // CaptureInput::scout
  int camera = 0;
  bool removed = false;
  int width = 0;  // working resolution
  int height = 0;
  std::optional<GeoFix> gps;
  Eigen::Vector3d gps_enu = Eigen::Vector3d::Zero();
  // Undistorted keypoints, working pixels; RootSIFT rows (CV_32F).
  std::vector<Eigen::Vector2d> keypoints;
  cv::Mat descriptors;
  std::vector<std::array<uint8_t, 3>> colors;
  // Gray patches around the detected keypoints, one CV_8U row each
  // (keypoint_refinement.h); empty for images restored from states written
  // before they were kept, whose keypoints then stay as detected.
  cv::Mat patches;
  std::vector<int64_t> point_of;  // per keypoint, -1 for none
  // Keypoints moved onto their track's reference by patch alignment, with
  // their new positions (already in `keypoints`). Kept in the state
  // because the features, stored apart once, hold the detected positions.
  std::vector<std::pair<int, Eigen::Vector2d>> refined_keypoints;
  bool registered = false;
  // The component (a separately reconstructed part of the site) a
  // registered image belongs to; meaningless while unregistered. The first
  // model's is 0.
  int component = 0;
  CaptureStatus status = CaptureStatus::kPending;
  std::string reason;
  int pose_inliers = 0;
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();  // world-to-camera
  Eigen::Vector3d t = Eigen::Vector3d::Zero();

  Eigen::Vector3d centre() const { return -(q.conjugate() * t); }
};

// Verified matches between two images (first < second) and their relative
// pose from the essential matrix (second = R * first + t, |t| = 1).
struct ImagePair {
  std::vector<std::pair<int, int>> matches;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  double median_angle_deg = 0;  // triangulation angle of the inliers
  double homography_ratio = 0;  // homography inliers / essential inliers
};

struct Scene {
  std::vector<SceneCamera> cameras;
  std::vector<SceneImage> images;
  std::map<std::pair<int, int>, ImagePair> pairs;
  std::map<int64_t, ScenePoint> points;
  int64_t next_point_id = 0;
  std::optional<Geodetic> enu_origin;  // fixed by the first fix
  bool geo_registered = false;         // world frame is ENU
  bool initialized = false;
  int registered_at_last_global_ba = 0;
  // A small model's inline global adjustment fell due in a call that
  // deferred it (CaptureInput::more_follow); the next call that does not
  // defer runs it (not serialized: a restored scene runs it at the next
  // registration that finds it due).
  bool global_ba_deferred = false;
  // Refinement rounds in a row that ended on their iteration cap while the
  // model kept its registered captures (`unsettled_at_count`); a capture
  // registered or a loop closed starts the count again (neither is
  // serialized: a restored scene starts counting again).
  int unsettled_refine_rounds = 0;
  int unsettled_at_count = -1;
  // add_capture stopped at its registration limit, so captures may be
  // waiting that the model's points would register now (not serialized: a
  // restored scene looks once).
  bool registration_backlog = false;
  // Gauge for models without GPS: the first pose is held fixed, and one
  // coordinate of the second image's position fixes the scale. Only the
  // first component can be in a frame of its own: later ones start only
  // once the model is in ENU, and are placed there as they form.
  int reference_image = -1;
  int scale_image = -1;
  // The id the next component started gets (the first model's is 0).
  int next_component = 1;
  // Pairs of unregistered images that failed to start a component, so that
  // every increment does not try them again (not serialized: a restored
  // scene tries once more).
  std::set<std::pair<int, int>> failed_component_pairs;
  // Registered pairs whose weaker corners the refinement has matched
  // (sfm/densify.cpp; not serialized: a restored scene looks again, and
  // finds the corners it matched already in the pair's matches).
  std::set<std::pair<int, int>> densified_pairs;
  // Loose pairs and the rounds that found their links strained
  // (sfm/loose_pairs.cpp; not serialized: a restored scene tries again).
  std::map<std::pair<int, int>, int> strained_tries;
  // Components may have become mergeable since the last look (a photo
  // registered or a component started; a restored scene looks once).
  bool merge_sweep_due = true;
  // A merge moved a component onto another, or a loop closure bent the
  // chain, since the refinement last settled on the model: cameras
  // may be off by decimetres where the seam's bounded adjustment did not
  // reach (not serialized: a restored scene refines in its turn).
  bool refinement_urgent = false;

  int registered_count() const;
  // Registered images per component id.
  std::map<int, int> component_sizes() const;
  // The component of a point: that of the images observing it.
  int component_of_point(int64_t id) const;
  int find_image(const std::string& id) const;  // -1 when absent
  const ImagePair* pair(int a, int b) const;
  // Pointers into `pairs` for every pair touching `image`, with the other
  // image's index.
  std::vector<std::pair<int, const ImagePair*>> pairs_of(int image) const;
  void remove_point(int64_t id);
  // Moves every observation of `gone` to `keep`, which moves to `xyz`.
  void merge_points(int64_t keep, int64_t gone, const Eigen::Vector3d& xyz);
  void add_observation(int64_t point, Observation obs);
  // Takes `obs` out of its point's track (none if its keypoint holds no
  // point), and the point out once fewer than two observations are left.
  void remove_observation(Observation obs);
  int64_t add_point(const Eigen::Vector3d& xyz,
                    const std::vector<Observation>& track);
};

// Takes `other` (another site's scene) in: its cameras (shared by id),
// photos, pairs and points after this scene's own, its components
// renumbered after this one's, its poses, points and fixes moved from its
// ENU frame into this one's (sfm/scene_absorb.cpp). Where a scene has
// registered photos it must be in ENU (the caller checks); the refinement
// and a merge sweep are due afterwards.
void absorb_scene(Scene& into, Scene&& other);

// The matches of a pair oriented so that `.first` is a keypoint of `image`
// (the pair's `other` image gives `.second`).
std::vector<std::pair<int, int>> oriented_matches(int image, int other,
                                                  const ImagePair& pair);

// Projects a world point with the working-resolution camera; false when it
// is behind the camera.
bool project(const SceneCamera& camera, const SceneImage& image,
             const Eigen::Vector3d& world, Eigen::Vector2d* pixel);

// The mean distance in working pixels between every observation and its
// point's projection, over the whole scene.
double mean_reprojection_px(const Scene& scene);

// Undistorted working pixel -> normalized camera ray (z = 1), removing the
// residual radial term by fixed-point iteration.
Eigen::Vector2d normalize(const SceneCamera& camera, const Eigen::Vector2d& px);

}  // namespace arscout::engine
