// GET /v1/sites/{id}/coverage (docs/api.md): the coverage analysis of the
// site's current model (engine/coverage.h) as GeoJSON.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "arscout/db/store.h"
#include "arscout/engine/coverage.h"
#include "arscout/engine/geo.h"
#include "arscout/http/http_types.h"

namespace arscout::viewer {

// The analysis as a FeatureCollection in WGS84 (lon, lat): facade cells as
// polygons, unseen facades as lines, suggestions as points with a rank,
// heights at the ground's.
nlohmann::json coverage_geojson(const engine::Coverage& coverage,
                                const engine::EnuFrame& frame);

// Each site's analysis at its current model version: a model version never
// changes, so it is analysed once (the engine state read dominates: seconds
// on a site of a hundred photos) and ranked for each scout's position.
// Thread-safe; holds one version per site, for at most kSites sites.
class CoverageCache {
 public:
  struct Entry {
    std::string site;  // the site the model is of (merges followed)
    std::int64_t version = 0;
    bool geo_registered = false;
    engine::EnuFrame frame;
    engine::Coverage coverage;  // every suggestion, ranked without `near`
  };
  std::shared_ptr<const Entry> current(db::Store& store,
                                       const std::string& site);

 private:
  static constexpr std::size_t kSites = 64;
  std::mutex mutex_;
  std::map<std::string, std::shared_ptr<const Entry>> entries_;
};

// The response for site `site` with the query's `near` ("lat,lon", the
// scout's position) and `max` (suggestions, 0-20, default 5): 400 for a bad
// `near`, 422 before the model is geo-registered, the store's errors (404
// for no site or no model yet) as the API states them.
http::HttpResponse site_coverage(CoverageCache& cache, db::Store& store,
                                 const http::HttpRequest& req,
                                 const std::string& site, int max);

}  // namespace arscout::viewer
