// Dense reconstruction (the paper's sections 3.4-3.5): plane-sweep depth maps
// for key views with their two best neighbours, a forward-backward
// consistency filter between depth maps, and fusion into one coloured point
// cloud de-duplicated on a voxel grid. Everything works on undistorted
// pinhole views at a dense working resolution; DenseReconstruction (in
// dense_reconstruction.h) drives it incrementally from a sparse Model.
// This header holds what callers outside the engine use (the views, the
// sweep and its options, depth maps); the consistency filter and the voxel
// grid are internal (engine/src/dense/consistency.h).
//
// Conventions: poses map world to camera, x_cam = R x_world + t, OpenCV
// camera axes; pixel centres at integer coordinates; depth is the camera z
// of the surface (not the distance along the ray), 0 where unknown.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace arscout::engine {

struct PlaneSweepOptions {
  int window = 7;  // ZNCC window side, pixels (odd, 3 to 31)
  // Depth range from the key view's sparse points (2nd and 98th
  // percentiles), widened by this fraction on each side.
  double depth_margin = 0.15;
  // Planes are spaced so that one step moves a pixel by about this much in
  // the neighbour with the widest baseline; sub-plane refinement does the
  // rest. Bounded by min_planes and max_planes per direction.
  double plane_step_px = 1.0;
  int min_planes = 48;
  int max_planes = 256;
  // Extra sweep directions along the dominant scene planes found in the
  // sparse points (Gallup et al. 2007); 0 sweeps fronto-parallel only.
  int max_scene_directions = 1;
  // One more direction, parallel to the ground, when the key view knows
  // which way is up (DenseView::up) and no scene direction found is within
  // 15 degrees of it. A street's ground is seen at a grazing angle, where a
  // fronto-parallel plane matches a window badly and the sparse points are
  // few (RANSAC finds the facade first): without it the ground is mostly
  // missing and the winners there are depths measured past it.
  bool ground_direction = true;
  // Rejection: a key window whose grey levels vary less than this (standard
  // deviation, 0-255) has too little texture; a winner below min_score or
  // beating the runner-up at another depth by less than min_margin is not
  // trusted.
  double min_texture = 1.0;
  // Aggregation over neighbours: the mean ZNCC, or the best neighbour's
  // less this penalty when that is higher (occlusion: the surface is hidden
  // from one neighbour). 0 keeps the best neighbour only.
  double occlusion_penalty = 0.2;
  double min_score = 0.35;
  double min_margin = 0.02;
  // Sky: the smooth region joined to the image's top row (5 x 5 grey
  // levels varying by less than this, standard deviation 0-255), grown
  // into the pixels of its colour along its edges, gets no depth
  // (dense/sky_mask.h); 0 turns the mask off.
  double sky_max_texture = 3.0;
  // Triangulation: a depth whose point the key's ray and every
  // neighbour's ray meet at less than this angle (degrees) is dropped. Near
  // a forward-moving camera's epipole the parallax between planes is a
  // fraction of a pixel, and a winner there is noise (COLMAP's
  // filter_min_triangulation_angle, 3 degrees with all its source views;
  // here a key has two neighbours, and depths at 2-4 degrees are asked for
  // a second agreeing map instead: ConsistencyOptions::
  // weak_triangulation_deg). 0 keeps every depth.
  double min_triangulation_deg = 2.0;
  bool use_cuda = false;  // the CUDA path, when built with ARSCOUT_CUDA
  // Strips over OpenCV's worker threads; false keeps the sweep on the
  // calling thread (the same map either way). A caller that sweeps beside
  // latency-critical work at a low priority wants that: OpenCV's shared
  // pool would otherwise run the sweep at full priority and leave the other
  // work's own parallel calls to run serially.
  bool parallel = true;
  // When set (and `parallel`), asked before each group of strips (one per
  // thread, a quarter of a sweep or so): false sweeps that group on the
  // calling thread. A caller whose latency-critical work may start at any
  // moment hands the pool back within a fraction of a sweep instead of
  // after the whole sweep. The map is the same either way.
  std::function<bool()> keep_parallel;
};

// A photo ready for the sweep: undistorted, at the dense working
// resolution, with its pose and the sparse points it observes.
struct DenseView {
  std::string id;
  cv::Mat bgr;  // CV_8UC3
  Eigen::Matrix3d K = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> sparse_points;  // world frame
  // The world's up (unit, world frame) when known: the site's ENU z once
  // the model is geo-registered; zero when unknown.
  Eigen::Vector3d up = Eigen::Vector3d::Zero();

  Eigen::Vector3d centre() const { return -R.transpose() * t; }
};

struct DepthMap {
  std::string id;  // the key view's
  cv::Mat depth;   // CV_32F, 0 = none
  cv::Mat score;   // CV_32F, winning aggregated ZNCC
  cv::Mat margin;  // CV_32F, winner minus runner-up at another depth
  Eigen::Matrix3d K = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();

  // Share of pixels with a depth.
  double coverage() const;
  // The world point seen at pixel (x, y) with depth z.
  Eigen::Vector3d unproject(double x, double y, double z) const;
};

// A sweep direction: planes n . X = d in the key camera's frame, with d
// spaced uniformly in 1/d from d_near to d_far.
struct SweepDirection {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // unit, key frame
  double d_near = 1;
  double d_far = 10;
  int planes = 64;
  // Planes parallel to the ground (PlaneSweepOptions::ground_direction):
  // the ground is opaque, so a depth of any direction whose point lies
  // farther below the camera than d_far is dropped.
  bool ground = false;
};

// The directions swept for `key`: fronto-parallel, plus up to
// max_scene_directions dominant planes among its sparse points, plus the
// ground when `ground_direction` and key.up is known and no scene plane is
// already parallel to it (its range: the offsets below the camera of the
// sparse points, the nearest at least a quarter of the farthest). Empty
// when the key sees too few sparse points to bound the depth range.
std::vector<SweepDirection> sweep_directions(
    const DenseView& key, const std::vector<const DenseView*>& neighbours,
    const PlaneSweepOptions& options);

// The plane sweep: for each direction and plane, warp each neighbour into
// the key view through the plane's homography, score windowed ZNCC (box
// filters, so the window size does not multiply the cost), aggregate over
// the neighbours (the mean, or the best less a penalty when one neighbour
// is occluded), winner-takes-all over all planes with a
// parabolic sub-plane refinement, then reject low texture, low score and
// low margin. Neighbours must have the key's image size. Multithreaded
// over image strips; deterministic.
DepthMap sweep_planes(const DenseView& key,
                      const std::vector<const DenseView*>& neighbours,
                      const PlaneSweepOptions& options);

struct ConsistencyOptions {
  double max_relative_depth = 0.01;  // |z_other - z_predicted| / z
  double max_reprojection_px = 1.0;  // back in the first map
  // A pixel's depth is fused once this many other maps agree with it
  // (each map is checked against its best-connected partners, and later
  // maps check themselves against it, so the count grows with the site).
  int min_agreeing_maps = 1;
  // Free-space conflicts: a pixel whose point another map sees through
  // (that map measured a surface farther than the point by more than this
  // share of its depth) counts against it, and a pixel is fused only while
  // more maps agree with it than see through it (docs/dense.md). 0 turns
  // the check off.
  double free_space_margin = 0.05;
  // Photometric confidence: a depth whose ZNCC beats the best score at
  // another depth by less than this (DepthMap::margin) is ambiguous
  // (repeated or faint texture, a window across a depth edge) and needs one
  // more agreeing map than min_agreeing_maps. 0 turns it off.
  double distinct_margin = 0.03;
  // Geometric confidence: a depth whose point every neighbour it was swept
  // with sees at less than this many degrees from the key's ray (little
  // parallax: far down a street a scout walks along) is weak as well, and
  // needs one more agreeing map. 0 turns it off.
  double weak_triangulation_deg = 4.0;
  bool parallel = true;  // rows over OpenCV's threads (PlaneSweepOptions)
};

// A square of the ground (x, y in the site frame) holding fused points,
// for readers that follow the cloud region by region (the service's mesh
// tiles): block (ix, iy) spans [ix * edge, (ix + 1) * edge) in x and the
// same in y, where edge is the cloud's block edge
// (DenseReconstruction::cloud_block_edge). `changed` is the stamp of its
// last change (DenseReconstruction::mark_cloud); `points` may be 0 (it lost
// its last one). Every point it holds has min_x <= x <= max_x and
// min_y <= y <= max_y (bounds of what it ever held: a removal does not
// shrink them), with the points' own float rounding.
struct CloudBlock {
  long long ix = 0, iy = 0;
  std::uint64_t changed = 0;
  std::size_t points = 0;
  float min_x = 0, min_y = 0, max_x = 0, max_y = 0;
};

}  // namespace arscout::engine
