#include "dense/map_fusion.h"

#include <algorithm>

#include "dense/depth_normals.h"

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

// The pixel's own map and those that agree with it.
uint8_t support_from(uint8_t agreed) {
  return static_cast<uint8_t>(std::min(255, agreed + 1));
}

}  // namespace

void MapFusion::reset(cv::Size size) {
  batch_of_ = cv::Mat::zeros(size, CV_8U);
  support_of_ = cv::Mat::zeros(size, CV_8U);
  batches_.clear();
}

const cv::Mat& MapFusion::normals(const FusionInput& in) {
  if (normal_of_.empty()) {
    const cv::Mat normals = depth_normals(*in.swept_depth, in.K, kNormalRadius);
    normals.convertTo(normal_of_, CV_8SC3, kNormalUnit);
  }
  return normal_of_;
}

Eigen::Vector3d MapFusion::point_of(const FusionInput& in, const Batch& batch,
                                    int x, int y) const {
  const float z = fused_depth(in.swept_depth->at<float>(y, x), batch.scale);
  return z * (batch.A * Eigen::Vector3d(x, y, 1)) + batch.b;
}

CloudSample MapFusion::sample_of(const FusionInput& in, const Batch& batch,
                                 const cv::Mat& normals, int x, int y,
                                 int support) const {
  CloudSample sample;
  sample.xyz = point_of(in, batch, x, y);
  sample.rgb = rgb_of(in.bgr->at<cv::Vec3b>(y, x));
  sample.support = support;
  if (in.score)
    sample.score = std::clamp(in.score->at<float>(y, x), 0.0f, 1.0f);
  const cv::Vec<schar, 3> n = normals.at<cv::Vec<schar, 3>>(y, x);
  const Eigen::Vector3d camera(n[0], n[1], n[2]);
  sample.normal = (batch.camera_to_world * camera / kNormalUnit).cast<float>();
  return sample;
}

const MapFusion::Batch& MapFusion::batch_at(int x, int y) const {
  return batches_[batch_of_.at<uint8_t>(y, x) - 1];
}

CloudSample MapFusion::added_sample(const FusionInput& in,
                                    const cv::Mat& normals, int x,
                                    int y) const {
  return sample_of(in, batch_at(x, y), normals, x, y,
                   support_of_.at<uint8_t>(y, x));
}

void MapFusion::update_fused(const FusionInput& in, VoxelCloud* cloud) {
  for (int y = 0; y < batch_of_.rows; ++y) {
    const uint8_t* agreed = in.agreed->ptr<uint8_t>(y);
    const uint8_t* conflicts = in.conflicts->ptr<uint8_t>(y);
    uint8_t* batch_of = batch_of_.ptr<uint8_t>(y);
    uint8_t* support_of = support_of_.ptr<uint8_t>(y);
    for (int x = 0; x < batch_of_.cols; ++x) {
      if (!batch_of[x]) continue;
      if (!fusable(agreed[x], conflicts[x], in.min_agreeing,
                   in.weak && in.weak->at<uint8_t>(y, x))) {
        cloud->remove(added_sample(in, normals(in), x, y));
        batch_of[x] = 0;
        continue;
      }
      const uint8_t support = support_from(agreed[x]);
      if (support == support_of[x]) continue;
      cloud->change_support(point_of(in, batch_at(x, y), x, y), support_of[x],
                            support);
      support_of[x] = support;
    }
  }
}

size_t MapFusion::add(const FusionInput& in, VoxelCloud* cloud) {
  if (batches_.size() >= 255) {
    remove(in, cloud);
    reset(batch_of_.size());
  }
  if (!batches_.empty()) update_fused(in, cloud);
  Batch batch;
  batch.A = in.R.transpose() * in.K.inverse();
  batch.camera_to_world = in.R.transpose();
  batch.b = -in.R.transpose() * in.t;
  batch.scale = in.scale;
  const uint8_t number = static_cast<uint8_t>(batches_.size() + 1);
  size_t added = 0;
  for (int y = 0; y < in.swept_depth->rows; ++y) {
    const float* depth = in.swept_depth->ptr<float>(y);
    const uint8_t* agreed = in.agreed->ptr<uint8_t>(y);
    const uint8_t* conflicts = in.conflicts->ptr<uint8_t>(y);
    uint8_t* batch_of = batch_of_.ptr<uint8_t>(y);
    uint8_t* support_of = support_of_.ptr<uint8_t>(y);
    for (int x = 0; x < in.swept_depth->cols; ++x) {
      if (batch_of[x] || depth[x] <= 0 ||
          !fusable(agreed[x], conflicts[x], in.min_agreeing,
                   in.weak && in.weak->at<uint8_t>(y, x)))
        continue;
      support_of[x] = support_from(agreed[x]);
      cloud->add(sample_of(in, batch, normals(in), x, y, support_of[x]));
      batch_of[x] = number;
      ++added;
    }
  }
  if (added > 0) batches_.push_back(batch);
  return added;
}

void MapFusion::remove(const FusionInput& in, VoxelCloud* cloud) {
  const cv::Mat& map_normals = normals(in);
  for (int y = 0; y < batch_of_.rows; ++y) {
    uint8_t* batch_of = batch_of_.ptr<uint8_t>(y);
    for (int x = 0; x < batch_of_.cols; ++x) {
      if (!batch_of[x]) continue;
      cloud->remove(added_sample(in, map_normals, x, y));
      batch_of[x] = 0;
    }
  }
  batches_.clear();
}

}  // namespace arscout::engine
