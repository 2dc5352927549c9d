// GeoJSON (RFC 7946) of the served forms, for web maps: sites as points at
// their centres, and a model's registered cameras at their positions with
// the direction they look. Positions are [longitude, latitude, ellipsoidal
// height in metres] on WGS84, as RFC 7946 orders them.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "arscout/documents/model.h"
#include "arscout/documents/site.h"

namespace arscout::documents {

// A FeatureCollection with one Point Feature per site ("id": the site id;
// properties name, captures, registered, model_version, state, radius_m,
// extent_m); a site without a centre yet has a null geometry.
nlohmann::json sites_geojson(
    const std::vector<std::pair<std::string, Site>>& sites);

// A FeatureCollection with one Point Feature per registered image of a
// geo-registered model that has a geodetic position ("id": the capture id;
// properties camera, heading_deg (clockwise from north, [0, 360)),
// pitch_deg (up positive), dense). Throws DocumentError when the model is
// not geo-registered: its frame has no north.
nlohmann::json cameras_geojson(const ModelDocument& model);

}  // namespace arscout::documents
