// What the engine takes from documents written by the API (docs/api.md),
// read with the documents library's one reader of each form: a capture's
// GPS fix as the engine's GeoFix, and a camera document's intrinsics.
#pragma once

#include <optional>
#include <string>

#include <nlohmann/json_fwd.hpp>

#include "arscout/documents/gps.h"
#include "arscout/engine/camera.h"
#include "arscout/engine/geo.h"
#include "arscout/engine/reconstruction.h"

namespace arscout::db {
class Store;
}

namespace arscout::engine::service {

// The fix as the engine weighs it: GeoFix's default accuracies stand in for
// those the fix does not state.
std::optional<GeoFix> geo_fix(const std::optional<documents::GpsFix>& gps);

// A camera document's intrinsics; nullopt when it is not a valid camera
// (documents::validate_camera) or not one the engine can use (validate()).
std::optional<CameraIntrinsics> camera_intrinsics(
    const nlohmann::json& camera_attrs);

// The blob holding a stored capture's photo. Throws std::invalid_argument
// when the capture is gone, std::runtime_error when it has no image.
std::string capture_image_sha(db::Store& store, const std::string& capture);

// What the engine takes from a stored capture, its photo's bytes given: its
// fix, its scout and its camera (the intrinsics of the camera document it
// names; an unnamed camera is one per photo size). Throws
// std::invalid_argument when the capture is gone.
CaptureInput capture_input(db::Store& store, const std::string& capture,
                           std::string image_bytes);

// The same with its photo's bytes read from the store, the capture's
// document read once. Throws as capture_image_sha does.
CaptureInput stored_capture_input(db::Store& store, const std::string& capture);

}  // namespace arscout::engine::service
