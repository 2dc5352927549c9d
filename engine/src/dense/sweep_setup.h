// What a plane sweep computes before it runs, the same for the CPU path
// (plane_sweep.cpp) and the CUDA path (plane_sweep_cuda.cu, which calls
// these on the host before its kernels start): grey images, the key's
// texture, and each plane's homography.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "arscout/engine/dense.h"

namespace arscout::engine::sweep_setup {

// `bgr` (CV_8UC3) as CV_32F grey levels in [0, 255].
cv::Mat grey_levels(const cv::Mat& bgr);

// The mean of `image` (CV_32F) over a window x window box, borders
// reflected (cv::BORDER_REFLECT), as the sweeps' window sums take them.
cv::Mat window_mean(const cv::Mat& image, int window);

// 1 / the standard deviation of `grey` (CV_32F) over the window, and 0
// where the variance is below min_texture^2: too little texture to score.
// Stores the window mean in *mean when given.
cv::Mat inverse_window_std(const cv::Mat& grey, int window, double min_texture,
                           cv::Mat* mean = nullptr);

// The homography taking key pixels to neighbour pixels for the plane
// n . X = d (key camera frame): K_n (R_rel + t_rel n^T / d) K_k^-1.
Eigen::Matrix3d plane_homography(const DenseView& key,
                                 const DenseView& neighbour,
                                 const Eigen::Vector3d& normal, double d);

}  // namespace arscout::engine::sweep_setup
