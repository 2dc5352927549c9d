// Decoding a photo at the engine's working resolution and removing lens
// distortion through a per-camera look-up table (the paper's section 3.1).
#pragma once

#include <string>

#include <opencv2/core.hpp>

#include "arscout/engine/camera.h"

namespace arscout::engine {

struct WorkingImage {
  cv::Mat color;  // BGR, 8-bit
  cv::Mat gray;
  int original_width = 0;
  int original_height = 0;
  double scale = 1;  // working / original
};

// Decodes JPEG or PNG bytes so that the long side is at most `long_side`
// (JPEGs are decoded directly at 1/2, 1/4 or 1/8 size when that leaves at
// least 90 % of `long_side`, which is much faster than decoding whole and
// shrinking). `original_size`
// (width, height), when known, saves reading the header. Throws
// std::invalid_argument when the bytes are not an image.
WorkingImage decode_working_image(const std::string& bytes, int long_side,
                                  cv::Size original_size);

// The camera at the working resolution: pixel centres stay at integer
// coordinates, so x_work = s * (x + 0.5) - 0.5.
cv::Matx33d working_k(const CameraIntrinsics& camera, double scale);

// Undistortion maps for one camera at one working size; the undistorted
// image keeps the working K (no cropping or zoom).
class Undistorter {
 public:
  Undistorter() = default;
  Undistorter(const CameraIntrinsics& camera, double scale, cv::Size size);
  bool identity() const { return map_x_.empty(); }
  cv::Mat apply(const cv::Mat& image) const;

 private:
  cv::Mat map_x_;
  cv::Mat map_y_;
};

}  // namespace arscout::engine
