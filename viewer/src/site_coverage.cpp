#include "site_coverage.h"

#include <cmath>
#include <stdexcept>

#include "arscout/viewer/site_model.h"

namespace arscout::viewer {
namespace {

using Json = nlohmann::json;
using http::HttpRequest;
using http::HttpResponse;

// [lon, lat] of an ENU point at the ground's height, to 1e-7 degrees
// (about a centimetre).
Json lon_lat(const engine::EnuFrame& frame, const std::array<double, 2>& xy,
             double z) {
  const engine::Geodetic g = frame.to_geodetic({xy[0], xy[1], z});
  const auto round7 = [](double v) { return std::round(v * 1e7) / 1e7; };
  return Json::array({round7(g.lon), round7(g.lat)});
}

Json feature(Json geometry, Json properties) {
  return {{"type", "Feature"},
          {"geometry", std::move(geometry)},
          {"properties", std::move(properties)}};
}

Json cell_feature(const engine::Coverage& c, const engine::CoverageCell& cell,
                  const engine::EnuFrame& frame) {
  const double h = c.cell_m / 2;
  Json ring = Json::array();
  for (const auto& [dx, dy] :
       {std::pair{-h, -h}, std::pair{h, -h}, std::pair{h, h}, std::pair{-h, h},
        std::pair{-h, -h}})
    ring.push_back(
        lon_lat(frame, {cell.centre[0] + dx, cell.centre[1] + dy}, c.ground_z));
  return feature({{"type", "Polygon"}, {"coordinates", Json::array({ring})}},
                 {{"feature", "cell"},
                  {"views", cell.views},
                  {"directions", cell.directions},
                  {"sectors", cell.sectors},
                  {"points", cell.points},
                  {"facing_deg", std::round(cell.facing_deg)}});
}

Json unseen_feature(const engine::Coverage& c, const engine::UnseenFacade& f,
                    const engine::EnuFrame& frame) {
  return feature(
      {{"type", "LineString"},
       {"coordinates", Json::array({lon_lat(frame, f.from, c.ground_z),
                                    lon_lat(frame, f.to, c.ground_z)})}},
      {{"feature", "unseen_facade"},
       {"length_m", std::round(f.length_m * 10) / 10},
       {"facing_deg", std::round(f.facing_deg)}});
}

Json suggestion_feature(const engine::Coverage& c,
                        const engine::ShotSuggestion& s, int rank,
                        const engine::EnuFrame& frame) {
  return feature({{"type", "Point"},
                  {"coordinates", lon_lat(frame, s.position, c.ground_z)}},
                 {{"feature", "suggestion"},
                  {"rank", rank},
                  {"kind", s.kind},
                  {"heading_deg", std::round(s.heading_deg)},
                  {"reason", s.reason},
                  {"score", std::round(s.score * 100) / 100}});
}

// "lat,lon" in degrees, else nullopt.
std::optional<engine::Geodetic> parse_lat_lon(const std::string& text) {
  const auto comma = text.find(',');
  if (comma == std::string::npos) return std::nullopt;
  try {
    std::size_t a = 0, b = 0;
    const std::string lat_text = text.substr(0, comma);
    const std::string lon_text = text.substr(comma + 1);
    const double lat = std::stod(lat_text, &a), lon = std::stod(lon_text, &b);
    if (a != lat_text.size() || b != lon_text.size() ||
        !(std::abs(lat) <= 90) || !(std::abs(lon) <= 180))
      return std::nullopt;
    return engine::Geodetic{lat, lon, 0};
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

}  // namespace

Json coverage_geojson(const engine::Coverage& c,
                      const engine::EnuFrame& frame) {
  Json features = Json::array();
  for (const engine::CoverageCell& cell : c.cells)
    features.push_back(cell_feature(c, cell, frame));
  for (const engine::UnseenFacade& f : c.unseen)
    features.push_back(unseen_feature(c, f, frame));
  for (std::size_t k = 0; k < c.suggestions.size(); ++k)
    features.push_back(suggestion_feature(c, c.suggestions[k],
                                          static_cast<int>(k + 1), frame));
  return {{"type", "FeatureCollection"},
          {"cell_m", std::round(c.cell_m * 100) / 100},
          {"standoff_m", std::round(c.standoff_m * 10) / 10},
          {"features", std::move(features)}};
}

std::shared_ptr<const CoverageCache::Entry> CoverageCache::current(
    db::Store& store, const std::string& site) {
  const SiteModel doc = load_site_model(store, site);
  {
    std::lock_guard lock(mutex_);
    auto it = entries_.find(doc.site);
    if (it != entries_.end() && it->second->version == doc.version)
      return it->second;
  }
  auto entry = std::make_shared<Entry>();
  SiteModel model;
  const engine::Model full = load_consistent_full_model(store, site, &model);
  entry->site = model.site;
  entry->version = model.version;
  entry->geo_registered = full.geo_registered && full.enu_origin.has_value();
  if (entry->geo_registered) {
    entry->frame = engine::EnuFrame(*full.enu_origin);
    engine::CoverageOptions options;
    options.max_suggestions = 1 << 20;  // all: ranked per request
    entry->coverage = engine::analyse_coverage(full, options);
  }
  std::lock_guard lock(mutex_);
  if (entries_.size() >= kSites && !entries_.count(entry->site))
    entries_.erase(entries_.begin());
  entries_[entry->site] = entry;
  return entry;
}

HttpResponse site_coverage(CoverageCache& cache, db::Store& store,
                           const HttpRequest& req, const std::string& site,
                           int max) {
  std::optional<engine::Geodetic> near;
  if (auto it = req.query.find("near"); it != req.query.end()) {
    near = parse_lat_lon(it->second);
    if (!near)
      return HttpResponse::error(
          400, "bad_request",
          "query parameter 'near' must be \"lat,lon\" in degrees");
  }
  const auto entry = cache.current(store, site);
  if (!entry->geo_registered)
    return HttpResponse::error(
        422, "not_geo_registered",
        "site " + entry->site +
            ": the model is not geo-registered yet (fewer than three "
            "registered captures with GPS), so it has no ground to map");
  std::optional<std::array<double, 2>> at;
  if (near) {
    const auto enu = entry->frame.to_enu(*near);
    at = std::array<double, 2>{enu[0], enu[1]};
  }
  engine::Coverage ranked = entry->coverage;
  ranked.suggestions = engine::rank_for(entry->coverage, at, max);
  Json body = coverage_geojson(ranked, entry->frame);
  body["site"] = entry->site;
  body["model_version"] = entry->version;
  HttpResponse r = HttpResponse::geojson(body);
  r.headers.emplace_back("Cache-Control", "no-cache");
  return r;
}

}  // namespace arscout::viewer
