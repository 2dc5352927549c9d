// GET /v1/sites/{id}/coverage (docs/api.md): the coverage analysis of the
// site's current model (engine/coverage.h) as GeoJSON.
#pragma once

#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "arscout/db/store.h"
#include "arscout/engine/coverage.h"
#include "arscout/engine/geo.h"
#include "arscout/ingest/http_types.h"

namespace arscout::viewer {

// The analysis as a FeatureCollection in WGS84 (lon, lat): facade cells as
// polygons, unseen facades as lines, suggestions as points with a rank,
// heights at the ground's.
nlohmann::json coverage_geojson(const engine::Coverage& coverage,
                                const engine::EnuFrame& frame);

// The response for site `site` with the query's `near` ("lat,lon", the
// scout's position) and `max` (suggestions, 0-20, default 5): 400 for a bad
// `near`, 422 before the model is geo-registered, the store's errors (404
// for no site or no model yet) as the API states them.
ingest::HttpResponse site_coverage(db::Store& store,
                                   const ingest::HttpRequest& req,
                                   const std::string& site, int max);

}  // namespace arscout::viewer
