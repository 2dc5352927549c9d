#include "dense/map_fusion.h"

namespace arscout::engine {
namespace {

// One rule for the depth a pixel fuses at, so that remove() recomputes the
// very point add() made.
float fused_depth(float swept, double scale) {
  return scale == 1 ? swept : static_cast<float>(swept * scale);
}

std::array<uint8_t, 3> rgb_of(const cv::Vec3b& bgr) {
  return {bgr[2], bgr[1], bgr[0]};
}

}  // namespace

void MapFusion::reset(cv::Size size) {
  batch_of_ = cv::Mat::zeros(size, CV_8U);
  batches_.clear();
}

// The point pixel (x, y) was added at, from its batch's pose and scale.
Eigen::Vector3d MapFusion::point_of(const FusionInput& in, int x, int y) const {
  const Batch& batch = batches_[batch_of_.at<uint8_t>(y, x) - 1];
  const float z = fused_depth(in.swept_depth->at<float>(y, x), batch.scale);
  return z * (batch.A * Eigen::Vector3d(x, y, 1)) + batch.b;
}

void MapFusion::withdraw_unfusable(const FusionInput& in, VoxelCloud* cloud) {
  for (int y = 0; y < batch_of_.rows; ++y) {
    const uint8_t* agreed = in.agreed->ptr<uint8_t>(y);
    const uint8_t* conflicts = in.conflicts->ptr<uint8_t>(y);
    const cv::Vec3b* bgr = in.bgr->ptr<cv::Vec3b>(y);
    uint8_t* batch_of = batch_of_.ptr<uint8_t>(y);
    for (int x = 0; x < batch_of_.cols; ++x) {
      if (!batch_of[x] || fusable(agreed[x], conflicts[x], in.min_agreeing))
        continue;
      cloud->remove(point_of(in, x, y), rgb_of(bgr[x]));
      batch_of[x] = 0;
    }
  }
}

size_t MapFusion::add(const FusionInput& in, VoxelCloud* cloud) {
  if (batches_.size() >= 255) {
    remove(in, cloud);
    reset(batch_of_.size());
  }
  if (!batches_.empty()) withdraw_unfusable(in, cloud);
  Batch batch;
  batch.A = in.R.transpose() * in.K.inverse();
  batch.b = -in.R.transpose() * in.t;
  batch.scale = in.scale;
  const uint8_t number = static_cast<uint8_t>(batches_.size() + 1);
  size_t added = 0;
  for (int y = 0; y < in.swept_depth->rows; ++y) {
    const float* depth = in.swept_depth->ptr<float>(y);
    const uint8_t* agreed = in.agreed->ptr<uint8_t>(y);
    const uint8_t* conflicts = in.conflicts->ptr<uint8_t>(y);
    const cv::Vec3b* bgr = in.bgr->ptr<cv::Vec3b>(y);
    uint8_t* batch_of = batch_of_.ptr<uint8_t>(y);
    for (int x = 0; x < in.swept_depth->cols; ++x) {
      if (batch_of[x] || depth[x] <= 0 ||
          !fusable(agreed[x], conflicts[x], in.min_agreeing))
        continue;
      const float z = fused_depth(depth[x], batch.scale);
      cloud->add(z * (batch.A * Eigen::Vector3d(x, y, 1)) + batch.b,
                 rgb_of(bgr[x]));
      batch_of[x] = number;
      ++added;
    }
  }
  if (added > 0) batches_.push_back(batch);
  return added;
}

void MapFusion::remove(const FusionInput& in, VoxelCloud* cloud) {
  for (int y = 0; y < batch_of_.rows; ++y) {
    const cv::Vec3b* bgr = in.bgr->ptr<cv::Vec3b>(y);
    uint8_t* batch_of = batch_of_.ptr<uint8_t>(y);
    for (int x = 0; x < batch_of_.cols; ++x) {
      if (!batch_of[x]) continue;
      cloud->remove(point_of(in, x, y), rgb_of(bgr[x]));
      batch_of[x] = 0;
    }
  }
  batches_.clear();
}

}  // namespace arscout::engine
