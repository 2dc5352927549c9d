// Evaluation of a reconstruction (a COLMAP text model) against ground truth:
// readers for the model and for the ground-truth formats of the shared data
// (../shared/data/README.md), a 7-DoF alignment, and the error figures the
// reconstruction tests assert on.
//
// Conventions: a Pose maps world to camera, x_cam = R * x_world + t, as in
// COLMAP. Readers throw std::runtime_error("PATH:LINE: what") on malformed
// input so a failing test names the offending line.
#pragma once

#include <cstdint>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace arscout::eval {

struct Pose {
  std::string name;  // image file name, e.g. "0000.jpg"
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();  // world-to-camera
  Eigen::Vector3d t = Eigen::Vector3d::Zero();      // world-to-camera
  int camera_id = -1;  // COLMAP CAMERA_ID; -1 where the source has none

  // The camera centre in world coordinates, -R^T t.
  Eigen::Vector3d centre() const { return -R.transpose() * t; }
  // The pose of a camera with world-to-camera rotation R and centre C.
  static Pose from_centre(std::string name, const Eigen::Matrix3d& R,
                          const Eigen::Vector3d& C);
};

// ---- COLMAP text model (images.txt, cameras.txt, points3D.txt) ----

// Image name -> pose. Each image is two lines (header, POINTS2D); the second
// may be empty. Duplicate names are an error.
std::map<std::string, Pose> read_colmap_images_txt(const std::string& path);

struct ColmapCamera {
  int id = 0;
  std::string model;  // e.g. "PINHOLE", "SIMPLE_RADIAL"
  int width = 0;
  int height = 0;
  std::vector<double> params;
};
// Camera id -> camera.
std::map<int, ColmapCamera> read_colmap_cameras_txt(const std::string& path);

struct ColmapPoint3D {
  std::uint64_t id = 0;
  Eigen::Vector3d xyz = Eigen::Vector3d::Zero();
  Eigen::Vector3i rgb = Eigen::Vector3i::Zero();  // 0..255
  double error = 0;                               // mean reprojection, px
  int track_length = 0;  // number of (IMAGE_ID, POINT2D_IDX) pairs
};
std::vector<ColmapPoint3D> read_colmap_points3d_txt(const std::string& path);

// One observation of a 3D point: a keypoint in an image.
struct TrackObservation {
  std::string image;   // image name
  Eigen::Vector2d xy;  // COLMAP pixels (pixel centres at +0.5)
};
// Point id -> its observations.
using Tracks = std::map<std::uint64_t, std::vector<TrackObservation>>;

// The tracks of images.txt: every POINTS2D entry with POINT3D_ID >= 0,
// grouped by that id.
Tracks read_colmap_tracks(const std::string& images_txt);

// ---- Ground truth ----

// Strecha: every NAME.camera file in `gt_dense_cameras_dir`, keyed by NAME
// (e.g. "0000.jpg"). The file's R is camera-to-world; it is transposed.
std::map<std::string, Pose> read_strecha_ground_truth(
    const std::string& gt_dense_cameras_dir);

// Middlebury *_par.txt: count line, then `name K(9) R(9) t(3)`, P = K[R|t].
std::map<std::string, Pose> read_middlebury_par(const std::string& par_txt);

struct GeoRow {
  double lat = 0;  // degrees, WGS84
  double lon = 0;  // degrees, WGS84
  double alt = 0;  // metres above the ellipsoid
};
// A CSV with a header naming at least image, latitude, longitude, altitude
// (any order, extra columns ignored): our cameras_geo.csv and the Strecha
// gps.csv / gps_truth.csv.
std::map<std::string, GeoRow> read_geo_csv(const std::string& path);

// ---- Alignment and comparison ----

// x -> scale * R * x + t.
struct Similarity {
  double scale = 1;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();

  Eigen::Vector3d apply(const Eigen::Vector3d& x) const {
    return scale * R * x + t;
  }
};

// Least-squares similarity taking from[i] to to[i] (Umeyama). Throws
// std::invalid_argument for mismatched sizes, fewer than 3 points, or points
// that all coincide. Collinear points leave the rotation about their line
// undetermined; centre errors are still meaningful then, rotation errors not.
Similarity fit_similarity(const std::vector<Eigen::Vector3d>& from,
                          const std::vector<Eigen::Vector3d>& to);

// The similarity the bulk of the points agree on: fit_similarity on all of
// them, then again on those whose residual is within five times the
// median residual, until that set stops changing (at most 10 rounds). A
// model whose cameras are mostly right but holds a small part placed apart
// (a component of three photos placed by its own GPS fixes) is aligned by
// the rest, not pulled toward the part. *used (when not null) gets how many
// points the last fit used. The same errors as fit_similarity.
Similarity fit_similarity_robust(const std::vector<Eigen::Vector3d>& from,
                                 const std::vector<Eigen::Vector3d>& to,
                                 int* used = nullptr);

// Maps a pose through the similarity: its centre goes to sim.apply(centre),
// its camera-to-world rotation R^T to sim.R * R^T.
Pose transform_pose(const Similarity& sim, const Pose& pose);

// Angle in degrees of the rotation taking a to b (of a * b^T).
double rotation_angle_deg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b);

struct CameraError {
  std::string name;
  double centre_error = 0;        // ground-truth units
  double rotation_error_deg = 0;  // after alignment
  // The centre error split in the true camera's frame: along its viewing
  // axis (depth) and across it, which tell scale drift from lateral drift.
  double along_axis_error = 0;
  double across_axis_error = 0;
};

struct PoseComparison {
  int matched = 0;                 // names in both estimate and truth
  int truth_count = 0;             // images in the ground truth
  double median_centre_error = 0;  // ground-truth units (metres for Strecha)
  double max_centre_error = 0;
  double median_rotation_error_deg = 0;
  double max_rotation_error_deg = 0;
  // The rotation errors once the one rotation that best maps the aligned
  // orientations onto the true ones (their chordal mean) is taken out: the
  // orientation errors between cameras. They differ from the above where
  // the centres' fit leaves the rotation loose, as about the line of a
  // nearly straight walk, where one common tilt shows in every camera.
  double median_relative_rotation_error_deg = 0;
  // RMS distance of the matched true centres from their centroid (the ring
  // radius for a ring of cameras): divide a centre error by it to get a
  // unit-free figure.
  double scene_scale = 0;
  Similarity alignment;              // estimated -> truth
  std::vector<CameraError> cameras;  // matched cameras, by name
};

// Matches by name, fits the similarity from estimated to true centres,
// applies it and measures what is left. Throws std::invalid_argument when
// fewer than 3 names match.
PoseComparison compare_to_ground_truth(
    const std::map<std::string, Pose>& estimated,
    const std::map<std::string, Pose>& truth);

// Median 3D distance in metres between a's and b's rows of the same name,
// both in a local east-north-up frame at b's first row. *matched (if not
// null) gets the number of common names. Throws std::invalid_argument when
// there are none.
double median_geo_distance(const std::map<std::string, GeoRow>& a,
                           const std::map<std::string, GeoRow>& b,
                           int* matched);

// ---- Observation fit: how well a set of poses explains the keypoints ----

// Reprojection residuals in pixels of the re-triangulated tracks.
struct ObservationFit {
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  int observations = 0;    // residuals measured
  int points = 0;          // tracks re-triangulated and measured
  int skipped_points = 0;  // tracks whose point ended behind a camera
  double median_px = kNaN;
  double mean_clipped_px = kNaN;                  // mean of min(residual, 4 px)
  double p90_px = kNaN;                           // 90th percentile
  std::map<std::string, double> image_median_px;  // by image name
};

// Re-triangulates every track with `poses` alone (DLT on undistorted
// normalised coordinates, then Gauss-Newton on the reprojection error) and
// measures what is left, so any set of poses in any frame (the model's own,
// ground truth) can be judged against the same keypoints. Residuals are in
// pixels of the undistorted image (the photo's, where there is no
// distortion). Observations of
// images without a pose drop out; a track needs two that remain. Intrinsics
// come from `cameras` through `camera_ids` (image name -> CAMERA_ID);
// supported models: SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV,
// FULL_OPENCV. Throws std::invalid_argument for a posed image in a track
// without a camera, or a camera of another model or parameter count.
ObservationFit fit_observations(const std::map<std::string, Pose>& poses,
                                const std::map<int, ColmapCamera>& cameras,
                                const std::map<std::string, int>& camera_ids,
                                const Tracks& tracks);

// Median of the values (mean of the middle two for an even count); NaN for
// none.
double median(std::vector<double> values);

}  // namespace arscout::eval
