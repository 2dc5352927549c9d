#include "dense/sky_mask.h"

#include <algorithm>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "dense/sweep_setup.h"

namespace arscout::engine {
namespace {

constexpr int kSkyWindow = 5;

// 255 where the window's grey levels vary by less than max_texture.
cv::Mat smooth_pixels(const cv::Mat& bgr, double max_texture) {
  const cv::Mat grey = sweep_setup::grey_levels(bgr);
  const cv::Mat mean = sweep_setup::window_mean(grey, kSkyWindow);
  const cv::Mat mean_sq = sweep_setup::window_mean(grey.mul(grey), kSkyWindow);
  const cv::Mat variance = mean_sq - mean.mul(mean);
  return variance < max_texture * max_texture;
}

// The labels of the smooth components that reach the top of the picture:
// in each column, the rows from its first non-black pixel to a window
// below it (where a window still reaches into a border, it is not smooth).
std::vector<uint8_t> top_labels(const cv::Mat& bgr, const cv::Mat& labels,
                                int count) {
  std::vector<uint8_t> reaches_top(count, 0);
  for (int x = 0; x < bgr.cols; ++x) {
    int y = 0;
    while (y < bgr.rows && bgr.at<cv::Vec3b>(y, x) == cv::Vec3b(0, 0, 0)) ++y;
    for (int end = std::min(bgr.rows, y + kSkyWindow + 1); y < end; ++y)
      reaches_top[labels.at<int32_t>(y, x)] = 1;
  }
  reaches_top[0] = 0;  // the label of the pixels that are not smooth
  return reaches_top;
}

}  // namespace

cv::Mat sky_mask(const cv::Mat& bgr, double max_texture) {
  cv::Mat sky = cv::Mat::zeros(bgr.size(), CV_8U);
  if (!(max_texture > 0) || bgr.empty()) return sky;
  const cv::Mat smooth = smooth_pixels(bgr, max_texture);
  cv::Mat labels;
  const int count = cv::connectedComponents(smooth, labels, 8, CV_32S);
  const std::vector<uint8_t> reaches_top = top_labels(bgr, labels, count);
  for (int y = 0; y < labels.rows; ++y) {
    const int32_t* label = labels.ptr<int32_t>(y);
    uint8_t* out = sky.ptr<uint8_t>(y);
    for (int x = 0; x < labels.cols; ++x)
      if (reaches_top[label[x]]) out[x] = 255;
  }
  return sky;
}

}  // namespace arscout::engine
