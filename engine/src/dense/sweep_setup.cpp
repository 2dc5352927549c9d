#include "dense/sweep_setup.h"

#include <cmath>

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

namespace arscout::engine::sweep_setup {

cv::Mat grey_levels(const cv::Mat& bgr) {
  cv::Mat grey, result;
  cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
  grey.convertTo(result, CV_32F);
  return result;
}

cv::Mat window_mean(const cv::Mat& image, int window) {
  cv::Mat result;
  cv::boxFilter(image, result, CV_32F, cv::Size(window, window),
                cv::Point(-1, -1), true, cv::BORDER_REFLECT);
  return result;
}

cv::Mat inverse_window_std(const cv::Mat& grey, int window, double min_texture,
                           cv::Mat* mean) {
  const cv::Mat m = window_mean(grey, window);
  const cv::Mat mean_sq = window_mean(grey.mul(grey), window);
  cv::Mat inverse(grey.size(), CV_32F);
  const float min_var = static_cast<float>(min_texture * min_texture);
  for (int y = 0; y < grey.rows; ++y) {
    const float* m1 = m.ptr<float>(y);
    const float* m2 = mean_sq.ptr<float>(y);
    float* inv = inverse.ptr<float>(y);
    for (int x = 0; x < grey.cols; ++x) {
      const float var = m2[x] - m1[x] * m1[x];
      inv[x] = var >= min_var && var > 0 ? 1.0f / std::sqrt(var) : 0.0f;
    }
  }
  if (mean) *mean = m;
  return inverse;
}

Eigen::Matrix3d plane_homography(const DenseView& key,
                                 const DenseView& neighbour,
                                 const Eigen::Vector3d& normal, double d) {
  const Eigen::Matrix3d R_rel = neighbour.R * key.R.transpose();
  const Eigen::Vector3d t_rel = neighbour.t - R_rel * key.t;
  return neighbour.K * (R_rel + t_rel * normal.transpose() / d) *
         key.K.inverse();
}

}  // namespace arscout::engine::sweep_setup
