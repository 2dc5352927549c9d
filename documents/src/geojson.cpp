#include "arscout/documents/geojson.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <nlohmann/json.hpp>

#include "arscout/documents/capture_status.h"
#include "arscout/documents/document_error.h"

namespace arscout::documents {
namespace {

using Json = nlohmann::json;

Json point(const GeoPoint& p) {
  return Json{{"type", "Point"}, {"coordinates", {p.lon, p.lat, p.alt}}};
}

Json collection(Json features) {
  return Json{{"type", "FeatureCollection"}, {"features", std::move(features)}};
}

constexpr double kDegrees = 180 / std::numbers::pi;

// The viewing direction (the camera's +z) in the ENU frame: the third row
// of the world-to-camera rotation, from its quaternion (w, x, y, z).
void heading_and_pitch(const std::array<double, 4>& q, double* heading,
                       double* pitch) {
  const double w = q[0], x = q[1], y = q[2], z = q[3];
  const double east = 2 * (x * z - w * y);
  const double north = 2 * (y * z + w * x);
  const double up = 1 - 2 * (x * x + y * y);
  const double norm = std::sqrt(east * east + north * north + up * up);
  *heading = std::atan2(east, north) * kDegrees;
  if (*heading < 0) *heading += 360;
  *pitch = std::asin(std::clamp(up / norm, -1.0, 1.0)) * kDegrees;
}

}  // namespace

Json sites_geojson(const std::vector<std::pair<std::string, Site>>& sites) {
  Json features = Json::array();
  for (const auto& [id, site] : sites) {
    features.push_back(
        {{"type", "Feature"},
         {"id", id},
         {"geometry", site.centre ? point(*site.centre) : Json(nullptr)},
         {"properties",
          {{"name", site.name},
           {"captures", site.captures.size()},
           {kRegisteredCount, site.registered},
           {"model_version", site.model_version},
           {"state", site.state},
           {"radius_m", site.radius_m},
           {"extent_m", site.extent_m}}}});
  }
  return collection(std::move(features));
}

Json cameras_geojson(const ModelDocument& model) {
  if (!model.geo_registered)
    throw DocumentError("site " + model.site +
                        ": the model is not geo-registered yet, so its "
                        "cameras have no place on a map");
  Json features = Json::array();
  for (const ModelImageEntry& image : model.images) {
    if (!image.geodetic) continue;
    double heading = 0, pitch = 0;
    heading_and_pitch(image.qvec, &heading, &pitch);
    features.push_back({{"type", "Feature"},
                        {"id", image.id},
                        {"geometry", point(*image.geodetic)},
                        {"properties",
                         {{"camera", image.camera},
                          {"heading_deg", heading},
                          {"pitch_deg", pitch},
                          {"dense", image.dense.value_or(false)}}}});
  }
  return collection(std::move(features));
}

}  // namespace arscout::documents
