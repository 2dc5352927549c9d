// What the engine takes from documents written by the API (docs/api.md),
// read with the documents library's one reader of each form: a capture's
// GPS fix as the engine's GeoFix, and a camera document's intrinsics.
#pragma once

#include <optional>

#include <nlohmann/json_fwd.hpp>

#include "arscout/documents/gps.h"
#include "arscout/engine/camera.h"
#include "arscout/engine/geo.h"

namespace arscout::engine::service {

// The fix as the engine weighs it: GeoFix's default accuracies stand in for
// those the fix does not state.
std::optional<GeoFix> geo_fix(const std::optional<documents::GpsFix>& gps);

// A camera document's intrinsics; nullopt when it is not a valid camera
// (documents::validate_camera) or not one the engine can use (validate()).
std::optional<CameraIntrinsics> camera_intrinsics(
    const nlohmann::json& camera_attrs);

}  // namespace arscout::engine::service
