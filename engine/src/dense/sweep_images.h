// The images a plane sweep starts from, computed the same way by the CPU
// path (plane_sweep.cpp) and the CUDA path (plane_sweep_cuda.cu, which
// calls these on the host before its kernels run).
#pragma once

#include <opencv2/core.hpp>

namespace arscout::engine::sweep_images {

// `bgr` (CV_8UC3) as CV_32F grey levels in [0, 255].
cv::Mat grey_levels(const cv::Mat& bgr);

// The mean of `image` (CV_32F) over a window x window box, borders
// reflected (cv::BORDER_REFLECT), as the sweeps' window sums take them.
cv::Mat window_mean(const cv::Mat& image, int window);

// 1 / the standard deviation of `grey` (CV_32F) over the window, and 0
// where the variance is below min_texture^2: too little texture to score.
// Stores the window mean in *mean when given.
cv::Mat inverse_window_std(const cv::Mat& grey, int window,
                           double min_texture, cv::Mat* mean = nullptr);

}  // namespace arscout::engine::sweep_images
