// The camera document of a calibrated camera (docs/api.md), for the service
// tests that put one straight into the store instead of uploading it.
#pragma once

#include <string>

#include "arscout/db/store.h"
#include "arscout/engine/camera.h"

namespace arscout::testing {

// Puts /cameras/{id}: K with source "calibrated" and, when `distortion` is
// not null, its terms [k1 k2 p1 p2 k3], in the camera document's one form
// (documents/camera.h).
inline void put_calibrated_camera(db::Store& store, const std::string& id,
                                  engine::CameraIntrinsics K,
                                  const db::Json& distortion = nullptr) {
  K.source = "calibrated";
  if (!distortion.is_null()) {
    double* terms[] = {&K.k1, &K.k2, &K.p1, &K.p2, &K.k3};
    for (size_t i = 0; i < 5 && i < distortion.size(); ++i)
      *terms[i] = distortion[i].get<double>();
  }
  store.put("/cameras/" + id, "camera", documents::to_json(K));
}

}  // namespace arscout::testing
