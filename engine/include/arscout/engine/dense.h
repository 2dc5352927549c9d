// Dense reconstruction (the paper's sections 3.4-3.5): plane-sweep depth maps
// for key views with their two best neighbours, a forward-backward
// consistency filter between depth maps, and fusion into one coloured point
// cloud de-duplicated on a voxel grid. Everything works on undistorted
// pinhole views at a dense working resolution; DenseReconstruction (in
// dense_reconstruction.h) drives it incrementally from a sparse Model.
//
// Conventions: poses map world to camera, x_cam = R x_world + t, OpenCV
// camera axes; pixel centres at integer coordinates; depth is the camera z
// of the surface (not the distance along the ray), 0 where unknown.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "arscout/engine/ply.h"

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
};

// The directions swept for `key`: fronto-parallel, plus up to
// max_scene_directions dominant planes among its sparse points. Empty when
// the key sees too few sparse points to bound the depth range.
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
  bool parallel = true;  // rows over OpenCV's threads (PlaneSweepOptions)
};

// Forward-backward check of `map` against `other`: a pixel agrees when its
// point, seen from `other`, lands where `other` has a depth within the
// tolerance, and `other`'s point there projects back within
// max_reprojection_px of the pixel. Returns CV_8U, 255 where it agrees.
cv::Mat agreement_mask(const DepthMap& map, const DepthMap& other,
                       const ConsistencyOptions& options);

// Median of |z_a - z_b| / z_b over the pixels of `a` whose points fall on a
// depth in `b` (no tolerance applied), and how many there were.
struct DepthAgreement {
  double median_relative_difference = 0;
  int compared = 0;
};
DepthAgreement compare_depth_maps(const DepthMap& a, const DepthMap& b);

// Points merged on a voxel grid: each occupied voxel keeps the mean
// position and colour of the points that fell into it, so overlapping depth
// maps do not pile up duplicates. Adding is incremental, and a point added
// can be taken out again (the map whose camera moved, DenseReconstruction).
class VoxelCloud {
 public:
  explicit VoxelCloud(double voxel_size);

  void add(const Eigen::Vector3d& xyz, const std::array<uint8_t, 3>& rgb);
  // Takes out a point add() put in, given the same xyz and rgb; a voxel
  // left empty is gone. False (and nothing changed) when no point can have
  // been added there: its voxel is empty.
  bool remove(const Eigen::Vector3d& xyz, const std::array<uint8_t, 3>& rgb);
  // The occupied voxels' means, in the order the voxels were first
  // occupied.
  std::vector<ColoredPoint> points() const;
  size_t size() const { return index_.size(); }
  double voxel_size() const { return voxel_size_; }
  void clear() {
    voxels_.clear();
    index_.clear();
  }

 private:
  struct Voxel {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    std::array<uint32_t, 3> rgb_sum{0, 0, 0};
    uint32_t count = 0;  // 0: emptied by remove(), skipped
  };
  void compact();

  double voxel_size_;
  std::vector<Voxel> voxels_;  // in first-seen order: deterministic output
  std::unordered_map<uint64_t, uint32_t> index_;  // voxel key -> voxels_
};

}  // namespace arscout::engine
