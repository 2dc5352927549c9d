// The camera document of a calibrated camera (docs/api.md), for the service
// tests that put one straight into the store instead of uploading it.
#pragma once

#include <string>

#include "arscout/db/store.h"
#include "arscout/engine/camera.h"

namespace arscout::testing {

// Puts /cameras/{id}: K's focal lengths, principal point and size, source
// "calibrated", and `distortion` ([k1 k2 p1 p2 k3]) when it is not null.
inline void put_calibrated_camera(db::Store& store, const std::string& id,
                                  const engine::CameraIntrinsics& K,
                                  const db::Json& distortion = nullptr) {
  db::Json attrs{{"fx", K.fx},
                 {"fy", K.fy},
                 {"cx", K.cx},
                 {"cy", K.cy},
                 {"width", K.width},
                 {"height", K.height},
                 {"source", "calibrated"}};
  if (!distortion.is_null()) attrs["distortion"] = distortion;
  store.put("/cameras/" + id, "camera", attrs);
}

}  // namespace arscout::testing
