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
// 255 / kDescriptorSteps, so that one byte stores each component exactly
// (COLMAP's scale): a RootSIFT component larger than 0.5 needs a quarter of
// the histogram's mass in one bin, which SIFT's clipping at 0.2 rules out.
// The matcher's 12-bit dot product (matcher.h) loses nothing more.
inline constexpr float kDescriptorSteps = 512;

// Each component of `descriptors` (CV_32F) rounded to the nearest step of
// 1 / kDescriptorSteps, at most 255 steps.
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
