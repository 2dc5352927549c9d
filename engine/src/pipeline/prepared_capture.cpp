#include "pipeline/prepared_capture.h"

#include <chrono>
#include <memory>
#include <stdexcept>

#include "runtime/stopwatch.h"

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

void check_camera(const CaptureInput& capture) {
  if (!capture.camera) return;
  if (std::string problem = validate(*capture.camera); !problem.empty())
    throw std::invalid_argument("capture " + capture.id +
                                ": camera: " + problem);
}

WorkingImage decode_capture(const CaptureInput& capture,
                            const ReconstructionOptions& options,
                            StageTimings& timings) {
  const auto start = std::chrono::steady_clock::now();
  const cv::Size known =
      capture.camera ? cv::Size(capture.camera->width, capture.camera->height)
                     : cv::Size();
  WorkingImage working =
      decode_working_image(capture.image_bytes, options.long_side, known);
  timings.decode_s = seconds_since(start);
  return working;
}

Features describe(const WorkingImage& working, const Undistorter& undistort,
                  const ReconstructionOptions& options, StageTimings& timings) {
  auto stage = std::chrono::steady_clock::now();
  const cv::Mat color = undistort.apply(working.color);
  const cv::Mat gray = undistort.apply(working.gray);
  timings.undistort_s = seconds_since(stage);
  stage = std::chrono::steady_clock::now();
  FeatureOptions feature_options;
  feature_options.max_features = options.max_features;
  Features features = extract_features(gray, color, feature_options);
  timings.features_s = seconds_since(stage);
  return features;
}

PreparedCapture prepare_capture(const CaptureInput& capture,
                                const ReconstructionOptions& options) {
  check_camera(capture);
  auto impl = std::make_shared<PreparedCapture::Impl>();
  impl->capture_id = capture.id;
  const WorkingImage working = decode_capture(capture, options, impl->timings);
  impl->original_width = working.original_width;
  impl->original_height = working.original_height;
  impl->scale = working.scale;
  impl->width = working.color.cols;
  impl->height = working.color.rows;
  impl->intrinsics = first_intrinsics(capture, working.original_width,
                                      working.original_height);
  const Undistorter undistort(impl->intrinsics, working.scale,
                              working.color.size());
  impl->features = describe(working, undistort, options, impl->timings);
  const StageTimings& t = impl->timings;
  impl->timings.total_s = t.decode_s + t.undistort_s + t.features_s;
  PreparedCapture prepared;
  prepared.impl_ = std::move(impl);
  return prepared;
}

}  // namespace arscout::engine
