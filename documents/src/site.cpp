#include "arscout/documents/site.h"

#include <algorithm>

#include <nlohmann/json.hpp>

#include "arscout/documents/capture_status.h"
#include "arscout/documents/document_error.h"
#include "json_fields.h"

namespace arscout::documents {
namespace {

using fields::Json;

std::vector<std::string> capture_list(const Json& attrs) {
  std::vector<std::string> captures;
  const Json* list = fields::find(attrs, "captures");
  if (!list) return captures;
  if (!list->is_array())
    throw DocumentError("site: captures must be a list of capture ids");
  for (const Json& id : *list) {
    if (!id.is_string())
      throw DocumentError("site: captures must be a list of capture ids");
    captures.push_back(id.get<std::string>());
  }
  return captures;
}

std::optional<GeoPoint> centre_of(const Json& attrs) {
  const Json* gps = fields::find(attrs, "gps");
  if (!gps) return std::nullopt;
  const auto lat = fields::number(*gps, "lat");
  const auto lon = fields::number(*gps, "lon");
  if (!lat || !lon) return std::nullopt;
  return GeoPoint{*lat, *lon, fields::number(*gps, "alt").value_or(0)};
}

}  // namespace

Json to_json(const Site& s) {
  Json j = {{"name", s.name},
            {"radius", s.radius_m},
            {"fixes", s.fixes},
            {"extent_m", s.extent_m},
            {"reach_m", s.reach_m},
            {"cameras", s.cameras},
            {"captures", s.captures},
            {"capture_count", s.captures.size()},
            {kRegisteredCount, s.registered},
            {"model_version", s.model_version},
            {"state", s.state},
            {"engine", s.engine}};
  if (!s.merged_into.empty()) j["merged_into"] = s.merged_into;
  if (s.centre)
    j["gps"] = {
        {"lat", s.centre->lat}, {"lon", s.centre->lon}, {"alt", s.centre->alt}};
  return j;
}

Site site_from_json(const Json& attrs, const std::string& id) {
  if (!attrs.is_object())
    throw DocumentError("site " + id + ": the attributes must be an object");
  Site s;
  s.name = fields::string_or(attrs, "name", id);
  s.radius_m = fields::number(attrs, "radius").value_or(0);
  s.fixes = static_cast<int>(fields::number(attrs, "fixes").value_or(0));
  s.extent_m = fields::number(attrs, "extent_m").value_or(0);
  // Sites stored before the footprint followed cameras reach their extent.
  s.reach_m = std::max(s.extent_m,
                       fields::number(attrs, "reach_m").value_or(s.extent_m));
  s.cameras = static_cast<int>(fields::number(attrs, "cameras").value_or(0));
  s.captures = capture_list(attrs);
  s.centre = centre_of(attrs);
  s.registered =
      static_cast<int>(fields::number(attrs, kRegisteredCount).value_or(0));
  s.model_version = static_cast<std::int64_t>(
      fields::number(attrs, "model_version").value_or(0));
  s.state = fields::string_or(attrs, "state");
  s.engine = fields::string_or(attrs, "engine");
  s.merged_into = fields::string_or(attrs, "merged_into");
  return s;
}

}  // namespace arscout::documents
