#include "features/feature_extractor.h"

#include <algorithm>
#include <cmath>

#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "features/keypoint_refinement.h"

namespace arscout::engine {
namespace {

std::vector<cv::Point2f> harris_corners(const cv::Mat& gray,
                                        const FeatureOptions& options) {
  std::vector<cv::Point2f> corners;
  cv::goodFeaturesToTrack(gray, corners, options.max_features, options.quality,
                          options.min_distance, cv::noArray(), 3,
                          /*useHarrisDetector=*/true, 0.04);
  if (corners.empty()) return corners;
  // Sub-pixel corners: the accuracy of every pose downstream rests on them.
  cv::cornerSubPix(
      gray, corners, cv::Size(3, 3), cv::Size(-1, -1),
      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 20,
                       0.01));
  return corners;
}

// RootSIFT (Arandjelovic and Zisserman): L1-normalise, then square roots, so
// Euclidean distance compares like the Hellinger kernel. Rows end up unit
// length, which the matcher relies on.
void root_sift(cv::Mat& descriptors) {
  for (int r = 0; r < descriptors.rows; ++r) {
    float* row = descriptors.ptr<float>(r);
    float sum = 0;
    for (int c = 0; c < descriptors.cols; ++c) sum += std::abs(row[c]);
    const float inv = sum > 0 ? 1.0f / sum : 0.0f;
    for (int c = 0; c < descriptors.cols; ++c) row[c] = std::sqrt(row[c] * inv);
  }
}

}  // namespace

void quantize_descriptors(cv::Mat& descriptors) {
  for (int r = 0; r < descriptors.rows; ++r) {
    float* row = descriptors.ptr<float>(r);
    for (int c = 0; c < descriptors.cols; ++c)
      row[c] =
          std::min(kMaxDescriptorSteps, std::round(row[c] * kDescriptorSteps)) /
          kDescriptorSteps;
  }
}

Features extract_features(const cv::Mat& gray, const cv::Mat& color,
                          const FeatureOptions& options) {
  const std::vector<cv::Point2f> corners = harris_corners(gray, options);
  std::vector<cv::KeyPoint> keypoints;
  keypoints.reserve(corners.size());
  // Upright descriptors (angle 0): scouts hold the camera level, and
  // dropping rotation invariance makes the descriptor more distinctive.
  for (const cv::Point2f& p : corners) {
    keypoints.emplace_back(p, options.descriptor_size, 0.0f);
  }
  Features features;
  if (keypoints.empty()) {
    features.descriptors = cv::Mat(0, 128, CV_32F);
    features.patches = cv::Mat(0, kPatchSide * kPatchSide, CV_8U);
    return features;
  }
  const cv::Ptr<cv::SIFT> sift = cv::SIFT::create();
  sift->compute(gray, keypoints, features.descriptors);
  root_sift(features.descriptors);
  quantize_descriptors(features.descriptors);
  features.keypoints.reserve(keypoints.size());
  features.colors.reserve(keypoints.size());
  for (const cv::KeyPoint& kp : keypoints) {
    features.keypoints.emplace_back(kp.pt.x, kp.pt.y);
    const int x =
        std::clamp(static_cast<int>(std::lround(kp.pt.x)), 0, color.cols - 1);
    const int y =
        std::clamp(static_cast<int>(std::lround(kp.pt.y)), 0, color.rows - 1);
    const cv::Vec3b bgr = color.at<cv::Vec3b>(y, x);
    features.colors.push_back({bgr[2], bgr[1], bgr[0]});
  }
  features.patches = extract_patches(gray, features.keypoints);
  return features;
}

}  // namespace arscout::engine
