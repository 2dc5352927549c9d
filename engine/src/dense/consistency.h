// The dense pipeline's inner stages, internal to the engine: the
// forward-backward consistency filter between depth maps and the voxel grid
// that fuses agreeing pixels into one cloud. DenseReconstruction
// (dense_reconstruction.h) is their only production caller; they are kept
// out of the public dense.h so that its interface is what other libraries
// use (the sweep, for bench/dense_bench), and the engine's tests reach them
// here (tests/engine adds engine/src to its include path).
//
// Conventions are dense.h's: poses map world to camera, depth is camera z,
// 0 where unknown.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "arscout/engine/dense.h"
#include "arscout/engine/ply.h"

namespace arscout::engine {

// Forward-backward check of `map` against `other`: a pixel agrees when its
// point, seen from `other`, lands where `other` has a depth within the
// tolerance, and `other`'s point there projects back within
// max_reprojection_px of the pixel. Returns CV_8U, 255 where it agrees.
cv::Mat agreement_mask(const DepthMap& map, const DepthMap& other,
                       const ConsistencyOptions& options);

// What `other` says of each pixel of `map`, from one pass over it: the
// pixels it agrees with (agreement_mask), and the free-space conflicts
// between the two maps. Where a point of `map` lands in `other` and
// `other` measured a surface farther than the point by more than
// free_space_margin of its depth, `other`'s ray crossed empty space where
// the point claims a surface: one of the two depths is wrong. The point's
// pixel is marked in `sees_through` (on `map`'s grid) and the pixel of
// `other` it landed on in `overshoots` (on `other`'s grid). An occluded
// point (a nearer surface in `other`) is neither. All CV_8U, 255 where it
// holds; the conflict masks are all zero when free_space_margin is 0.
struct PairVerdict {
  cv::Mat agrees;        // map's grid
  cv::Mat sees_through;  // map's grid
  cv::Mat overshoots;    // other's grid
};
PairVerdict judge_pair(const DepthMap& map, const DepthMap& other,
                       const ConsistencyOptions& options);

// The one rule for whether a pixel is fused, given how many maps agree
// with it and how many are in free-space conflict with it (either side of
// PairVerdict): at least min_agreeing_maps agree, and more agree than
// conflict. Fusion and the filtered maps both ask it.
inline bool fusable(uint8_t agreed, uint8_t conflicts, int min_agreeing_maps) {
  return agreed >= min_agreeing_maps && agreed > conflicts;
}
// The same for a pixel whose own measurement is weak (`weak`: an ambiguous
// match or a narrow triangulation, weak_depths()): it needs one more
// agreeing map.
inline bool fusable(uint8_t agreed, uint8_t conflicts, int min_agreeing_maps,
                    bool weak) {
  return fusable(agreed, conflicts, min_agreeing_maps + (weak ? 1 : 0));
}

// CV_8U, 255 where `map` has a depth whose point each camera centre of
// `centres` (world frame) sees at less than `min_degrees` from the map's
// own ray: the parallax there is too small to pin the depth down. All zero
// when min_degrees is 0 or there is no centre (nothing to judge by).
cv::Mat narrow_triangulation(const DepthMap& map,
                             const std::vector<Eigen::Vector3d>& centres,
                             double min_degrees);

// CV_8U, 255 where a depth of `map`, swept with the neighbours whose
// centres are `neighbour_centres`, is weak: its match is ambiguous (margin
// under options.distinct_margin) or its triangulation narrow (under
// options.weak_triangulation_deg). fusable() asks one more agreeing map
// of such a pixel.
cv::Mat weak_depths(const DepthMap& map,
                    const std::vector<Eigen::Vector3d>& neighbour_centres,
                    const ConsistencyOptions& options);

// Median of |z_a - z_b| / z_b over the pixels of `a` whose points fall on a
// depth in `b` (no tolerance applied), and how many there were.
struct DepthAgreement {
  double median_relative_difference = 0;
  int compared = 0;
};
DepthAgreement compare_depth_maps(const DepthMap& a, const DepthMap& b);

// What one depth-map pixel brings to the cloud: its point and colour, the
// surface normal there (unit, toward its camera; zero when unknown), its
// support (how many maps measured it; 0 when unknown) and its score (the
// sweep's winning ZNCC, 0 to 1; 0 when unknown).
struct CloudSample {
  Eigen::Vector3d xyz = Eigen::Vector3d::Zero();
  std::array<uint8_t, 3> rgb{0, 0, 0};
  Eigen::Vector3f normal = Eigen::Vector3f::Zero();
  int support = 0;
  float score = 0;
};

// Points merged on a voxel grid: each occupied voxel keeps the mean
// position, colour, normal, support and score of the samples that fell
// into it, so
// overlapping depth maps do not pile up duplicates. Adding is incremental,
// and a sample added can be taken out again (the map whose camera moved,
// DenseReconstruction).
class VoxelCloud {
 public:
  explicit VoxelCloud(double voxel_size);

  void add(const CloudSample& sample);
  void add(const Eigen::Vector3d& xyz, const std::array<uint8_t, 3>& rgb) {
    add(CloudSample{xyz, rgb});
  }
  // Takes out a sample add() put in, given the same sample; a voxel left
  // empty is gone. False (and nothing changed) when no sample can have been
  // added there: its voxel is empty.
  bool remove(const CloudSample& sample);
  bool remove(const Eigen::Vector3d& xyz, const std::array<uint8_t, 3>& rgb) {
    return remove(CloudSample{xyz, rgb});
  }
  // A sample added at `xyz` with support `from` now has support `to` (more
  // maps came to agree with it, or fewer). False when its voxel is empty.
  bool change_support(const Eigen::Vector3d& xyz, int from, int to);
  // The occupied voxels' means (the normal normalised, the support rounded
  // and at most 255, the score times 255 and rounded), in the order the
  // voxels were first occupied.
  std::vector<ColoredPoint> points() const;
  size_t size() const { return index_.size(); }
  double voxel_size() const { return voxel_size_; }
  void clear();

  // The ground cut into blocks of kBlockVoxels x kBlockVoxels voxel columns,
  // aligned with the voxels: every block that has held a point since the
  // cloud was made or cleared (one emptied since has 0 points: a reader
  // sees that it changed), with the stamp of its last change (an add,
  // remove or change_support there). Stamps come from one counter per
  // process: a cloud made, or cleared, after mark() returned m changes
  // only with stamps above m, so a reader that keeps m may follow a
  // cloud that is replaced by another.
  static constexpr int kBlockVoxels = 16;
  double block_edge() const { return kBlockVoxels * voxel_size_; }
  std::vector<CloudBlock> blocks() const;
  // The stamp of the changes so far; later changes carry a larger one.
  uint64_t mark();
  // points() of the voxels whose means lie in [lo, hi) on the ground (x
  // and y), in the same order; reads only the blocks there.
  std::vector<ColoredPoint> points_in(const Eigen::Vector2d& lo,
                                      const Eigen::Vector2d& hi) const;

 private:
  struct Voxel {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    Eigen::Vector3f normal_sum = Eigen::Vector3f::Zero();
    std::array<uint32_t, 3> rgb_sum{0, 0, 0};
    uint32_t support_sum = 0;
    uint32_t score_sum = 0;  // thousandths: removal undoes add exactly
    uint32_t count = 0;      // 0: emptied by remove(), skipped
    uint32_t block = 0;      // in blocks_
  };
  struct Block {
    long long ix = 0, iy = 0;
    uint64_t changed = 0;
    uint32_t occupied = 0;         // voxels with a sample
    std::vector<uint32_t> voxels;  // slots in voxels_, ascending
    // Of the samples' x and y as floats: a mean lies within them.
    float min_x = kNone, min_y = kNone, max_x = -kNone, max_y = -kNone;
  };
  static constexpr float kNone = std::numeric_limits<float>::infinity();
  Voxel* find(const Eigen::Vector3d& xyz);
  // The block of a voxel key, made when new.
  uint32_t block_of(uint64_t voxel_key);
  void touch(const Voxel& voxel) { blocks_[voxel.block].changed = stamp_; }
  ColoredPoint mean_of(const Voxel& voxel) const;
  void compact();

  double voxel_size_;
  std::vector<Voxel> voxels_;  // in first-seen order: deterministic output
  std::unordered_map<uint64_t, uint32_t> index_;  // voxel key -> voxels_
  std::vector<Block> blocks_;
  std::unordered_map<uint64_t, uint32_t> block_index_;  // -> blocks_
  uint64_t stamp_;
};

}  // namespace arscout::engine
