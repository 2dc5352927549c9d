#include "dense/sky_mask.h"

#include <algorithm>
#include <cstdlib>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "dense/sweep_setup.h"

namespace arscout::engine {
namespace {

constexpr int kSkyWindow = 5;
// The smooth region stops a few pixels short of an edge (a roof, a cloud's
// rim), where the 5 x 5 window reaches over it; the sweep's window, wider,
// gives those pixels the edge's depth. The mask grows into them, a pixel
// at a time, while each is within kGrowTolerance (grey levels, any
// channel) of the sky pixel beside it: the anti-aliased blend at the edge
// stops it.
constexpr int kGrowSteps = 6;
constexpr int kGrowTolerance = 8;

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

bool alike(const cv::Vec3b& a, const cv::Vec3b& b) {
  for (int c = 0; c < 3; ++c)
    if (std::abs(a[c] - b[c]) > kGrowTolerance) return false;
  return true;
}

// One step of growth: the pixels beside the mask (4-connected) whose
// colour is alike that of a masked pixel beside them.
void grow_once(const cv::Mat& bgr, cv::Mat* sky) {
  const cv::Mat before = sky->clone();
  const int dx[4] = {1, -1, 0, 0}, dy[4] = {0, 0, 1, -1};
  for (int y = 0; y < bgr.rows; ++y) {
    for (int x = 0; x < bgr.cols; ++x) {
      if (before.at<uint8_t>(y, x)) continue;
      const cv::Vec3b& colour = bgr.at<cv::Vec3b>(y, x);
      if (colour == cv::Vec3b(0, 0, 0)) continue;  // undistortion's border
      for (int k = 0; k < 4; ++k) {
        const int u = x + dx[k], v = y + dy[k];
        if (u < 0 || v < 0 || u >= bgr.cols || v >= bgr.rows ||
            !before.at<uint8_t>(v, u) ||
            !alike(colour, bgr.at<cv::Vec3b>(v, u)))
          continue;
        sky->at<uint8_t>(y, x) = 255;
        break;
      }
    }
  }
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
  for (int step = 0; step < kGrowSteps; ++step) grow_once(bgr, &sky);
  return sky;
}

}  // namespace arscout::engine
