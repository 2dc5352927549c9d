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

struct Features {
  std::vector<Eigen::Vector2d> keypoints;      // sub-pixel, image pixels
  cv::Mat descriptors;                         // CV_32F, one unit row each
  std::vector<std::array<uint8_t, 3>> colors;  // RGB at each keypoint
  // The gray patch around each keypoint (keypoint_refinement.h).
  cv::Mat patches;
};

// `gray` and `color` (BGR) are the same undistorted working image.
Features extract_features(const cv::Mat& gray, const cv::Mat& color,
                          const FeatureOptions& options);

}  // namespace arscout::engine
