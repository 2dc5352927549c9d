// Harris corners (the paper's detector) with SIFT descriptors computed at
// them, upright and RootSIFT-normalised, for wide-baseline matching. The
// measurements behind this choice are in bench/FEATURES.md.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace arscout::engine {

struct FeatureOptions {
  int max_features = 4000;
  // Low, so that small or weakly textured photos still get corners; big
  // ones keep their max_features strongest.
  double quality = 0.0001;  // of the strongest Harris response
  double min_distance = 5;  // pixels between corners
  // SIFT support, pixels: small windows suit corners (bench/FEATURES.md),
  // and the cost grows with the square of this.
  float descriptor_size = 6;
};

// Descriptors are kept to steps of 1 / kDescriptorSteps, at most
// kMaxDescriptorSteps of them, so that two bytes store each component
// exactly (a unit row's components are at most 1). One byte (COLMAP's 1/512)
// was tried: matching moved enough that the temple ring's sparse test lost
// most of its cameras; 1/65536 is below the matcher's own 12-bit rows
// (matcher.h).
inline constexpr float kDescriptorSteps = 65536;
inline constexpr float kMaxDescriptorSteps = 65535;

// Each component of `descriptors` (CV_32F) rounded to the nearest step of
// 1 / kDescriptorSteps, at most kMaxDescriptorSteps steps.
void quantize_descriptors(cv::Mat& descriptors);

struct Features {
  std::vector<Eigen::Vector2d> keypoints;  // sub-pixel, image pixels
  // CV_32F, one row each, unit length to within the steps' rounding, every
  // component a whole number of steps (quantize_descriptors).
  cv::Mat descriptors;
  std::vector<std::array<uint8_t, 3>> colors;  // RGB at each keypoint
  // The gray patch around each keypoint (keypoint_refinement.h).
  cv::Mat patches;
};

// `gray` and `color` (BGR) are the same undistorted working image.
Features extract_features(const cv::Mat& gray, const cv::Mat& color,
                          const FeatureOptions& options);

}  // namespace arscout::engine
