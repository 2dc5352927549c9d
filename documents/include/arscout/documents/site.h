// The site form: the attributes of /sites/{id} (docs/service.md), written
// by the engine service when it places captures and commits a model.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

namespace arscout::documents {

// A point on the WGS84 ellipsoid: degrees, and metres of ellipsoidal height.
struct GeoPoint {
  double lat = 0;
  double lon = 0;
  double alt = 0;
};

struct Site {
  std::string name;
  double radius_m = 0;  // captures within it of the footprint join the site
  int fixes = 0;        // captures placed by their GPS fix
  // The footprint: the centre and `extent_m` cover the registered cameras
  // (`cameras` of them); before any, the founding capture's fix. `reach_m`
  // (>= extent_m) also covers fixes of captures not yet registered, a
  // bounded distance beyond (docs/service.md, "Placement").
  double extent_m = 0;
  double reach_m = 0;
  int cameras = 0;
  std::vector<std::string> captures;
  std::optional<GeoPoint> centre;  // none before the first fix
  // Of the last model the engine committed.
  int registered = 0;
  std::int64_t model_version = 0;
  // "waiting" (no model yet), "modelled", or "merged": the site grew into
  // another, `merged_into`, which holds its captures and model since.
  std::string state;
  std::string engine;  // the worker that committed it
  std::string merged_into;
};

// {"name", "radius", "fixes", "extent_m", "reach_m", "cameras", "captures",
//  "capture_count",
//  "gps": {"lat", "lon", "alt"} (with a centre), registered (the count),
//  "model_version", "state", "engine", "merged_into" (when merged)}.
nlohmann::json to_json(const Site& site);

// Reads what a site document holds (lenient, like capture_from_json: a
// missing field reads as its default; "name" defaults to `id`). Throws
// DocumentError when `attrs` is not an object or "captures" is not a list
// of strings: the engine places captures by that list.
Site site_from_json(const nlohmann::json& attrs, const std::string& id);

}  // namespace arscout::documents
