#include "capture_document.h"

#include "arscout/documents/document_error.h"

namespace arscout::engine::service {

std::optional<GeoFix> geo_fix(const std::optional<documents::GpsFix>& gps) {
  if (!gps) return std::nullopt;
  GeoFix fix;
  fix.lat = gps->lat;
  fix.lon = gps->lon;
  fix.alt = gps->alt;
  if (gps->h_acc) fix.h_acc = *gps->h_acc;
  if (gps->v_acc) fix.v_acc = *gps->v_acc;
  return fix;
}

std::optional<CameraIntrinsics> camera_intrinsics(const nlohmann::json& attrs) {
  try {
    CameraIntrinsics k = documents::camera_from_json(attrs);
    if (!validate(k).empty()) return std::nullopt;
    return k;
  } catch (const documents::DocumentError&) {
    return std::nullopt;
  }
}

}  // namespace arscout::engine::service
