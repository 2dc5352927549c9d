// The Scene (working resolution, undistorted pixels) as a Model (original
// photo pixels, refined intrinsics, geodetic positions).
#pragma once

#include "arscout/engine/model.h"
#include "scene/scene.h"

namespace arscout::engine {

Model build_model(const Scene& scene);

// The refined intrinsics of a scene camera in original-photo pixels: the
// focal length and residual radial terms from bundle adjustment combined
// with the distortion the look-up table removed.
CameraIntrinsics refined_intrinsics(const SceneCamera& camera);

}  // namespace arscout::engine
