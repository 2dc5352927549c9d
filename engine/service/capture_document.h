// What the engine reads from documents written by the API (docs/api.md):
// a capture's GPS fix (attrs.gps) and a camera's intrinsics (/cameras/{id}).
#pragma once

#include <optional>

#include <nlohmann/json.hpp>

#include "arscout/engine/camera.h"
#include "arscout/engine/geo.h"

namespace arscout::engine::service {

// attrs.gps {lat, lon, alt?, h_acc?, v_acc?} as a fix; nullopt without
// lat and lon.
std::optional<GeoFix> capture_fix(const nlohmann::json& capture_attrs);

// {fx, fy, cx, cy, width, height, distortion [k1 k2 p1 p2 k3], source};
// nullopt when incomplete or not a usable camera (validate()).
std::optional<CameraIntrinsics> camera_intrinsics(
    const nlohmann::json& camera_attrs);

}  // namespace arscout::engine::service
