// Bilinear sampling of a BGR image, clamped to its pixels (centres at
// integer coordinates): the atlas's levelling reads photos, the renderer
// reads atlases.
#pragma once

#include <algorithm>

#include <opencv2/core.hpp>

namespace arscout::engine::mesh {

inline cv::Vec3d sample_bilinear(const cv::Mat& bgr, double x, double y) {
  x = std::clamp(x, 0.0, bgr.cols - 1.001);
  y = std::clamp(y, 0.0, bgr.rows - 1.001);
  const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
  const double fx = x - x0, fy = y - y0;
  cv::Vec3d out;
  for (int dy = 0; dy < 2; ++dy)
    for (int dx = 0; dx < 2; ++dx) {
      const cv::Vec3b c = bgr.at<cv::Vec3b>(y0 + dy, x0 + dx);
      out += cv::Vec3d(c[0], c[1], c[2]) *
             ((dx ? fx : 1 - fx) * (dy ? fy : 1 - fy));
    }
  return out;
}

}  // namespace arscout::engine::mesh
