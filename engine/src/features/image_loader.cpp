#include "features/image_loader.h"

#include "arscout/engine/image_size.h"

#include <algorithm>
#include <stdexcept>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace arscout::engine {
namespace {

int reduced_decode_flag(int factor) {
  switch (factor) {
    case 2:
      return cv::IMREAD_REDUCED_COLOR_2;
    case 4:
      return cv::IMREAD_REDUCED_COLOR_4;
    case 8:
      return cv::IMREAD_REDUCED_COLOR_8;
    default:
      return cv::IMREAD_COLOR;
  }
}

bool is_jpeg(const std::string& bytes) {
  return bytes.size() > 3 && static_cast<unsigned char>(bytes[0]) == 0xFF &&
         static_cast<unsigned char>(bytes[1]) == 0xD8;
}

}  // namespace

WorkingImage decode_working_image(const std::string& bytes, int long_side,
                                  cv::Size original_size) {
  const cv::Mat buffer(1, static_cast<int>(bytes.size()), CV_8U,
                       const_cast<char*>(bytes.data()));
  if (original_size.width <= 0) {
    if (auto size = read_image_size(bytes))
      original_size = {size->width, size->height};
  }
  int factor = 1;
  // Reduced decoding rounds sizes up; only use it when the size is known
  // and divides exactly, so the pixel grid maps back without a half-pixel
  // question. A result up to 10 % below `long_side` is accepted: decoding
  // 3072 px photos at 1536 is several times faster than at 1600.
  if (is_jpeg(bytes) && original_size.width > 0) {
    const int long_original =
        std::max(original_size.width, original_size.height);
    // Whole pixels: the decoder's reduced sizes divide exactly.
    auto reduced = [&](int f) { return long_original / f; };
    while (factor < 8 && reduced(factor * 2) >= 0.9 * long_side &&
           original_size.width % (factor * 2) == 0 &&
           original_size.height % (factor * 2) == 0) {
      factor *= 2;
    }
  }
  WorkingImage result;
  // Sensor orientation (EXIF rotation ignored): the camera model and the
  // size in the header then describe the same pixels.
  cv::Mat decoded = cv::imdecode(
      buffer, reduced_decode_flag(factor) | cv::IMREAD_IGNORE_ORIENTATION);
  if (decoded.empty()) {
    throw std::invalid_argument(
        "the image cannot be decoded (not a JPEG or PNG?)");
  }
  const bool header_agrees = decoded.cols * factor == original_size.width &&
                             decoded.rows * factor == original_size.height;
  if (factor > 1 && !header_agrees) {
    throw std::invalid_argument(
        "the image's header and its pixels disagree about its size");
  }
  result.original_width = factor == 1 ? decoded.cols : original_size.width;
  result.original_height = factor == 1 ? decoded.rows : original_size.height;
  const int long_now = std::max(decoded.cols, decoded.rows);
  if (long_now > long_side) {
    const double shrink = static_cast<double>(long_side) / long_now;
    cv::resize(decoded, decoded,
               cv::Size(static_cast<int>(std::lround(decoded.cols * shrink)),
                        static_cast<int>(std::lround(decoded.rows * shrink))),
               0, 0, cv::INTER_AREA);
  }
  result.color = decoded;
  result.scale = static_cast<double>(decoded.cols) / result.original_width;
  cv::cvtColor(decoded, result.gray, cv::COLOR_BGR2GRAY);
  return result;
}

cv::Matx33d working_k(const CameraIntrinsics& c, double s) {
  return {s * c.fx, 0,        s * (c.cx + 0.5) - 0.5,
          0,        s * c.fy, s * (c.cy + 0.5) - 0.5,
          0,        0,        1};
}

Undistorter::Undistorter(const CameraIntrinsics& camera, double scale,
                         cv::Size size) {
  if (!camera.has_distortion()) return;
  const cv::Matx33d k = working_k(camera, scale);
  const std::vector<double> distortion{camera.k1, camera.k2, camera.p1,
                                       camera.p2, camera.k3};
  cv::initUndistortRectifyMap(k, distortion, cv::noArray(), k, size, CV_16SC2,
                              map_x_, map_y_);
}

cv::Mat Undistorter::apply(const cv::Mat& image) const {
  if (identity()) return image;
  cv::Mat out;
  cv::remap(image, out, map_x_, map_y_, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
  return out;
}

}  // namespace arscout::engine
