// What one depth map put into the fused cloud, so that it can be taken out
// again, point for point, when the map's camera moves: the dense phase then
// re-fuses only the maps whose cameras moved, not the whole cloud
// (DenseReconstruction::update).
//
// Each pixel brings its normal (from its neighbours' depths) and its
// support: 1 + the maps that agree with it, kept up to date as maps come
// and go.
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
  // CV_8U, 255 where the depth is weak (weak_depths(): one more map must
  // agree); null: none is.
  const cv::Mat* weak = nullptr;
  // CV_32F, the sweep's winning ZNCC (DepthMap::score); null: unknown.
  const cv::Mat* score = nullptr;
  const cv::Mat* bgr = nullptr;
  Eigen::Matrix3d K = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
};

class MapFusion {
 public:
  // Nothing of a map of `size` pixels is in any cloud. The map's normals,
  // once computed, are kept: a MapFusion serves one swept map for its
  // whole life (a map swept again gets a new one).
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
    Eigen::Matrix3d camera_to_world;  // R^T: turns the map's normals
    double scale = 1;
  };
  // Takes out the fused pixels no longer fusable and brings the others'
  // support up to date.
  void update_fused(const FusionInput& in, VoxelCloud* cloud);
  // The map's normals in its camera frame, as int8 units of 1/kNormalUnit
  // (CV_8SC3: 3 bytes a pixel, under half a degree of rounding), computed
  // at the first call: the swept depths never change, and add() and
  // remove() must see the same normal for a pixel.
  const cv::Mat& normals(const FusionInput& in);
  const Batch& batch_at(int x, int y) const;  // of a pixel in the cloud
  Eigen::Vector3d point_of(const FusionInput& in, const Batch& batch, int x,
                           int y) const;
  // What pixel (x, y) brings from `batch`'s pose and scale (its normal
  // from the map's depths, dense/depth_normals.h), with `support`.
  CloudSample sample_of(const FusionInput& in, const Batch& batch,
                        const cv::Mat& normals, int x, int y,
                        int support) const;
  // The sample pixel (x, y) was added as.
  CloudSample added_sample(const FusionInput& in, const cv::Mat& normals, int x,
                           int y) const;

  // A 13 x 13 window: the sweep's depth noise over a few pixels would turn
  // the normal every which way on a surface seen head-on (on the rendered
  // street at 320 x 240, 31 % of the normals within 15 degrees from
  // neighbouring pixels' depths, 62 % from a 9 x 9 fit, 71 % from 13 x 13).
  static constexpr int kNormalRadius = 6;
  static constexpr double kNormalUnit = 127;

  cv::Mat batch_of_;    // CV_8U: 0 = not in the cloud, else 1 + the batch
  cv::Mat support_of_;  // CV_8U: the support it was added with, or last
                        // changed to
  cv::Mat normal_of_;   // CV_8SC3: normals(), once computed
  std::vector<Batch> batches_;
};

}  // namespace arscout::engine
