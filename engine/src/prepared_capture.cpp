#include "prepared_capture.h"

#include <chrono>
#include <memory>
#include <stdexcept>

#include "features/image_loader.h"
#include "stopwatch.h"

namespace arscout::engine {

CameraIntrinsics first_intrinsics(const CaptureInput& capture,
                                  int original_width, int original_height) {
  return capture.camera ? *capture.camera
                        : guessed_camera(original_width, original_height);
}

bool same_geometry(const CameraIntrinsics& a, const CameraIntrinsics& b) {
  return a.width == b.width && a.height == b.height && a.fx == b.fx &&
         a.fy == b.fy && a.cx == b.cx && a.cy == b.cy && a.k1 == b.k1 &&
         a.k2 == b.k2 && a.p1 == b.p1 && a.p2 == b.p2 && a.k3 == b.k3;
}

PreparedCapture::PreparedCapture() = default;
PreparedCapture::~PreparedCapture() = default;
PreparedCapture::PreparedCapture(const PreparedCapture&) = default;
PreparedCapture& PreparedCapture::operator=(const PreparedCapture&) = default;

const std::string& PreparedCapture::capture_id() const {
  static const std::string none;
  return impl_ ? impl_->capture_id : none;
}

StageTimings PreparedCapture::timings() const {
  return impl_ ? impl_->timings : StageTimings{};
}

PreparedCapture prepare_capture(const CaptureInput& capture,
                                const ReconstructionOptions& options) {
  if (capture.camera) {
    if (std::string problem = validate(*capture.camera); !problem.empty()) {
      throw std::invalid_argument("capture " + capture.id +
                                  ": camera: " + problem);
    }
  }
  auto impl = std::make_shared<PreparedCapture::Impl>();
  impl->capture_id = capture.id;
  StageTimings& timings = impl->timings;
  auto stage = std::chrono::steady_clock::now();
  const cv::Size known =
      capture.camera ? cv::Size(capture.camera->width, capture.camera->height)
                     : cv::Size();
  const WorkingImage working =
      decode_working_image(capture.image_bytes, options.long_side, known);
  timings.decode_s = seconds_since(stage);
  impl->original_width = working.original_width;
  impl->original_height = working.original_height;
  impl->scale = working.scale;
  impl->width = working.color.cols;
  impl->height = working.color.rows;
  impl->intrinsics = first_intrinsics(capture, working.original_width,
                                      working.original_height);

  stage = std::chrono::steady_clock::now();
  const Undistorter undistort(impl->intrinsics, working.scale,
                              working.color.size());
  const cv::Mat color = undistort.apply(working.color);
  const cv::Mat gray = undistort.apply(working.gray);
  timings.undistort_s = seconds_since(stage);

  stage = std::chrono::steady_clock::now();
  FeatureOptions feature_options;
  feature_options.max_features = options.max_features;
  impl->features = extract_features(gray, color, feature_options);
  timings.features_s = seconds_since(stage);
  timings.total_s = timings.decode_s + timings.undistort_s + timings.features_s;
  PreparedCapture prepared;
  prepared.impl_ = std::move(impl);
  return prepared;
}

}  // namespace arscout::engine
