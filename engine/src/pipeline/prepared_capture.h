// The contents of a PreparedCapture (arscout/engine/reconstruction.h): a
// photo decoded, undistorted and described, apart from any model.
#pragma once

#include <string>

#include "arscout/engine/reconstruction.h"
#include "features/feature_extractor.h"
#include "features/image_loader.h"

namespace arscout::engine {

struct PreparedCapture::Impl {
  std::string capture_id;
  int original_width = 0;  // of the photo
  int original_height = 0;
  double scale = 1;  // working / original
  int width = 0;     // of the working image
  int height = 0;
  // The intrinsics it was undistorted with: a site whose camera for the
  // capture holds others prepares the photo again.
  CameraIntrinsics intrinsics;
  Features features;
  StageTimings timings;  // decode, undistort, features
};

// The intrinsics a photo is undistorted with when its camera is new to a
// site: the capture's own, else the guess from the photo's size.
CameraIntrinsics first_intrinsics(const CaptureInput& capture,
                                  int original_width, int original_height);

// Equal numbers where undistortion reads them (size, focal lengths,
// principal point, distortion), whatever the source says.
bool same_geometry(const CameraIntrinsics& a, const CameraIntrinsics& b);

// Throws std::invalid_argument naming the capture when the camera it
// carries is not usable (validate()).
void check_camera(const CaptureInput& capture);

// The stages add_capture and prepare_capture share, each timed into
// `timings`: the photo decoded at the working resolution (throws
// std::invalid_argument when it cannot be), then undistorted through
// `undistort` and described.
WorkingImage decode_capture(const CaptureInput& capture,
                            const ReconstructionOptions& options,
                            StageTimings& timings);
Features describe(const WorkingImage& working, const Undistorter& undistort,
                  const ReconstructionOptions& options, StageTimings& timings);

}  // namespace arscout::engine
