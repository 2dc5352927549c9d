#include "site_directory.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>

namespace arscout::engine::service {

double distance_m(double lat1, double lon1, double lat2, double lon2) {
  constexpr double kRadius = 6371008.8;  // WGS84 mean radius
  constexpr double kRad = M_PI / 180;
  const double dlat = (lat2 - lat1) * kRad, dlon = (lon2 - lon1) * kRad;
  const double a = std::sin(dlat / 2) * std::sin(dlat / 2) +
                   std::cos(lat1 * kRad) * std::cos(lat2 * kRad) *
                       std::sin(dlon / 2) * std::sin(dlon / 2);
  return 2 * kRadius * std::asin(std::min(1.0, std::sqrt(a)));
}

std::string SiteDirectory::sanitise(const std::string& text) {
  std::string out;
  for (char c : text) {
    const bool ok = std::isalnum(static_cast<unsigned char>(c)) || c == '.' ||
                    c == '_' || c == '-';
    out += ok ? c : '_';
  }
  return out.substr(0, 120);
}

void SiteDirectory::load(const std::map<std::string, Json>& sites) {
  std::lock_guard lock(mutex_);
  for (const auto& [id, attrs] : sites) {
    Site site;
    site.id = id;
    site.name = attrs.value("name", id);
    const Json gps = attrs.value("gps", Json::object());
    site.lat = gps.value("lat", 0.0);
    site.lon = gps.value("lon", 0.0);
    site.alt = gps.value("alt", 0.0);
    site.fixes = attrs.value("fixes", 0);
    site.extent_m = attrs.value("extent_m", 0.0);
    for (const Json& c : attrs.value("captures", Json::array())) {
      site.captures.push_back(c.get<std::string>());
      capture_site_[c.get<std::string>()] = id;
    }
    sites_[id] = std::move(site);
  }
}

std::optional<std::string> SiteDirectory::site_of(
    const std::string& capture) const {
  std::lock_guard lock(mutex_);
  auto it = capture_site_.find(capture);
  if (it == capture_site_.end()) return std::nullopt;
  return it->second;
}

std::optional<std::string> SiteDirectory::place(
    const std::string& capture, const std::optional<GeoFix>& fix,
    const std::string& hint) {
  std::lock_guard lock(mutex_);
  if (auto it = capture_site_.find(capture); it != capture_site_.end())
    return it->second;
  Site* chosen = nullptr;
  if (fix) {
    double best = std::numeric_limits<double>::infinity();
    for (auto& [id, site] : sites_) {
      if (site.fixes == 0) continue;  // a hint-only site has no centre
      const double d =
          distance_m(fix->lat, fix->lon, site.lat, site.lon) - site.extent_m;
      if (d <= radius_m_ && d < best) {
        best = d;
        chosen = &site;
      }
    }
  } else if (!hint.empty()) {
    for (auto& [id, site] : sites_)
      if (site.name == hint) chosen = &site;
  } else {
    return std::nullopt;
  }
  if (!chosen) {
    Site site;
    site.id =
        fix || hint.empty() ? "s-" + sanitise(capture) : "h-" + sanitise(hint);
    site.name = fix || hint.empty() ? site.id : hint;
    chosen = &(sites_[site.id] = std::move(site));
  }
  if (fix) {
    // The running mean of the fixes: the centre follows the captures.
    const double n = chosen->fixes;
    const double old_lat = chosen->lat, old_lon = chosen->lon;
    chosen->lat = (chosen->lat * n + fix->lat) / (n + 1);
    chosen->lon = (chosen->lon * n + fix->lon) / (n + 1);
    chosen->alt = (chosen->alt * n + fix->alt.value_or(chosen->alt)) / (n + 1);
    const double moved =
        n > 0 ? distance_m(old_lat, old_lon, chosen->lat, chosen->lon) : 0;
    chosen->extent_m =
        std::max(chosen->extent_m + moved,
                 distance_m(fix->lat, fix->lon, chosen->lat, chosen->lon));
    ++chosen->fixes;
  }
  chosen->captures.push_back(capture);
  capture_site_[capture] = chosen->id;
  return chosen->id;
}

std::optional<Site> SiteDirectory::site(const std::string& id) const {
  std::lock_guard lock(mutex_);
  auto it = sites_.find(id);
  if (it == sites_.end()) return std::nullopt;
  return it->second;
}

std::vector<Site> SiteDirectory::sites() const {
  std::lock_guard lock(mutex_);
  std::vector<Site> out;
  for (const auto& [id, site] : sites_) out.push_back(site);
  return out;
}

Json SiteDirectory::to_attrs(const Site& site, double radius_m) {
  Json attrs = {
      {"name", site.name},         {"radius", radius_m},
      {"fixes", site.fixes},       {"extent_m", site.extent_m},
      {"captures", site.captures}, {"capture_count", site.captures.size()}};
  if (site.fixes > 0)
    attrs["gps"] = {{"lat", site.lat}, {"lon", site.lon}, {"alt", site.alt}};
  return attrs;
}

}  // namespace arscout::engine::service
