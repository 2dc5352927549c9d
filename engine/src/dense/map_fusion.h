// What one depth map put into the fused cloud, so that it can be taken out
// again, point for point, when the map's camera moves: the dense phase then
// re-fuses only the maps whose cameras moved, not the whole cloud
// (DenseReconstruction::update).
//
// A map's pixels enter the cloud in batches: all its agreeing pixels when it
// is first fused, then the pixels a later neighbour's map comes to agree
// with. Each batch is seen from the pose (and depth scale) of its time; the
// pixel remembers its batch, so removal recomputes exactly the points that
// were added.
#pragma once

#include <cstddef>
#include <vector>

#include <Eigen/Dense>
#include <opencv2/core.hpp>

#include "dense/consistency.h"

namespace arscout::engine {

// A depth map's pixels as fusion sees them: depths as swept (CV_32F, 0 =
// none) times `scale`, how many other maps agree with each pixel and how
// many are in free-space conflict with it (CV_8U each; fusable() with
// `min_agreeing` says whether it is fused), the key view's colours (CV_8UC3,
// BGR), all of one size, and the camera.
struct FusionInput {
  const cv::Mat* swept_depth = nullptr;
  double scale = 1;
  const cv::Mat* agreed = nullptr;
  const cv::Mat* conflicts = nullptr;
  int min_agreeing = 1;
  const cv::Mat* bgr = nullptr;
  Eigen::Matrix3d K = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
};

class MapFusion {
 public:
  // Nothing of a map of `size` pixels is in any cloud.
  void reset(cv::Size size);
  bool empty() const { return batches_.empty(); }

  // Takes out the pixels added that are no longer fusable (later maps came
  // into free-space conflict with them), then adds the fusable pixels not added
  // yet as one batch seen from `in`'s pose; returns how many it added. Past 255
  // batches the map is taken out and added again whole (the batch number
  // is a byte per pixel).
  size_t add(const FusionInput& in, VoxelCloud* cloud);
  // Takes every point added out of `cloud` again (the depths and colours
  // must be those given to add(); the pose and scale are the batches').
  void remove(const FusionInput& in, VoxelCloud* cloud);

 private:
  struct Batch {
    Eigen::Matrix3d A;  // X = z A (x, y, 1) + b: unproject() without K^-1
    Eigen::Vector3d b;
    double scale = 1;
  };
  void withdraw_unfusable(const FusionInput& in, VoxelCloud* cloud);
  Eigen::Vector3d point_of(const FusionInput& in, int x, int y) const;

  cv::Mat batch_of_;  // CV_8U: 0 = not in the cloud, else 1 + the batch
  std::vector<Batch> batches_;
};

}  // namespace arscout::engine
