#include "site_directory.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>

#include "arscout/util/geodesy.h"

namespace arscout::engine::service {

std::string SiteDirectory::sanitise(const std::string& text) {
  std::string out;
  for (char c : text) {
    const bool ok = std::isalnum(static_cast<unsigned char>(c)) || c == '.' ||
                    c == '_' || c == '-';
    out += ok ? c : '_';
  }
  return out.substr(0, 120);
}

Footprint registered_footprint(const Model& model) {
  Footprint fp;
  for (const ModelImage& image : model.images) {
    if (!image.geodetic) continue;
    fp.lat += image.geodetic->lat;
    fp.lon += image.geodetic->lon;
    fp.alt += image.geodetic->alt;
    ++fp.cameras;
  }
  if (fp.cameras == 0) return fp;
  fp.lat /= fp.cameras;
  fp.lon /= fp.cameras;
  fp.alt /= fp.cameras;
  for (const ModelImage& image : model.images) {
    if (!image.geodetic) continue;
    fp.extent_m = std::max(
        fp.extent_m, util::great_circle_m(fp.lat, fp.lon, image.geodetic->lat,
                                          image.geodetic->lon));
  }
  return fp;
}

void SiteDirectory::load(const std::map<std::string, Json>& sites) {
  std::lock_guard lock(mutex_);
  for (const auto& [id, attrs] : sites) {
    const documents::Site stored = documents::site_from_json(attrs, id);
    Site site;
    site.id = id;
    site.name = stored.name;
    if (stored.centre) {
      site.lat = stored.centre->lat;
      site.lon = stored.centre->lon;
      site.alt = stored.centre->alt;
    }
    site.fixes = stored.fixes;
    site.extent_m = stored.extent_m;
    site.reach_m = stored.reach_m;
    site.cameras = stored.cameras;
    site.captures = stored.captures;
    site.merged_into = stored.merged_into;
    for (const std::string& capture : site.captures)
      capture_site_[capture] = id;
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
    const std::string& hint, const std::string& name) {
  std::lock_guard lock(mutex_);
  if (auto it = capture_site_.find(capture); it != capture_site_.end())
    return it->second;
  Site* chosen = nullptr;
  if (fix) {
    double best = std::numeric_limits<double>::infinity();
    for (auto& [id, site] : sites_) {
      // A hint-only site has no centre; a merged one takes nothing.
      if (site.fixes == 0 || !site.merged_into.empty()) continue;
      const double d =
          util::great_circle_m(fix->lat, fix->lon, site.lat, site.lon) -
          site.reach_m;
      if (d <= radius_m_ && d < best) {
        best = d;
        chosen = &site;
      }
    }
  } else if (!hint.empty()) {
    // By id, not name: a site renamed (PATCH /v1/sites/{id}) keeps its hint.
    auto it = sites_.find(current_locked("h-" + sanitise(hint)));
    if (it != sites_.end() && it->second.merged_into.empty())
      chosen = &it->second;
  } else {
    return std::nullopt;
  }
  if (!chosen) {
    Site site;
    site.id =
        fix || hint.empty() ? "s-" + sanitise(capture) : "h-" + sanitise(hint);
    site.name = fix || hint.empty() ? (name.empty() ? site.id : name) : hint;
    chosen = &(sites_[site.id] = std::move(site));
  }
  if (fix) {
    if (chosen->fixes == 0) {  // it founds the site: its fix is the centre
      chosen->lat = fix->lat;
      chosen->lon = fix->lon;
      chosen->alt = fix->alt.value_or(0);
    }
    ++chosen->fixes;
    chosen->unconfirmed[capture] = *fix;
    widen(*chosen, *fix);
  }
  chosen->captures.push_back(capture);
  capture_site_[capture] = chosen->id;
  return chosen->id;
}

std::optional<std::string> SiteDirectory::place_in(const std::string& capture,
                                                   const std::string& id) {
  std::lock_guard lock(mutex_);
  if (auto it = capture_site_.find(capture); it != capture_site_.end())
    return it->second;
  const std::string at = current_locked(id);
  auto site = sites_.find(at);
  if (site == sites_.end() || !site->second.merged_into.empty())
    return std::nullopt;
  site->second.captures.push_back(capture);
  capture_site_[capture] = at;
  return at;
}

void SiteDirectory::widen(Site& site, const GeoFix& fix) const {
  const double from_centre =
      util::great_circle_m(fix.lat, fix.lon, site.lat, site.lon);
  site.reach_m = std::max(
      site.reach_m,
      std::min(from_centre, site.extent_m + kUnconfirmedReach * radius_m_));
}

bool SiteDirectory::follow(const std::string& id, const Footprint& cameras,
                           const std::vector<std::string>& settled) {
  std::lock_guard lock(mutex_);
  auto it = sites_.find(id);
  if (it == sites_.end()) return false;
  Site& site = it->second;
  for (const std::string& capture : settled) site.unconfirmed.erase(capture);
  if (cameras.cameras > 0) {
    site.lat = cameras.lat;
    site.lon = cameras.lon;
    site.alt = cameras.alt;
    site.extent_m = cameras.extent_m;
    site.cameras = cameras.cameras;
    site.reach_m = site.extent_m;
    for (const auto& [capture, fix] : site.unconfirmed) widen(site, fix);
  }
  return true;
}

std::vector<std::string> SiteDirectory::meeting(const std::string& site,
                                                const GeoFix& fix) const {
  std::lock_guard lock(mutex_);
  std::vector<std::pair<double, std::string>> near;
  for (const auto& [id, other] : sites_) {
    if (id == site || other.fixes == 0 || !other.merged_into.empty()) continue;
    const double d =
        util::great_circle_m(fix.lat, fix.lon, other.lat, other.lon) -
        other.reach_m;
    if (d <= radius_m_) near.push_back({d, id});
  }
  std::sort(near.begin(), near.end());
  std::vector<std::string> result;
  for (const auto& [d, id] : near) result.push_back(id);
  return result;
}

void SiteDirectory::join_footprints(Site& kept, const Site& gone) {
  // Weighed by cameras (a site without any by its founding fix); each disc
  // covered what it covered before.
  const double n = std::max(kept.cameras, 1), m = std::max(gone.cameras, 1);
  const double lat = (kept.lat * n + gone.lat * m) / (n + m);
  const double lon = (kept.lon * n + gone.lon * m) / (n + m);
  double extent = 0, reach = 0;
  for (const Site* s : {static_cast<const Site*>(&kept), &gone}) {
    const double shift = util::great_circle_m(lat, lon, s->lat, s->lon);
    extent = std::max(extent, shift + s->extent_m);
    reach = std::max(reach, shift + s->reach_m);
  }
  kept.alt = (kept.alt * n + gone.alt * m) / (n + m);
  kept.lat = lat;
  kept.lon = lon;
  kept.extent_m = extent;
  kept.reach_m = reach;
  kept.cameras += gone.cameras;
}

bool SiteDirectory::merge(const std::string& from, const std::string& into) {
  std::lock_guard lock(mutex_);
  auto a = sites_.find(into), b = sites_.find(from);
  if (from == into || a == sites_.end() || b == sites_.end() ||
      !a->second.merged_into.empty() || !b->second.merged_into.empty())
    return false;
  Site& kept = a->second;
  Site& gone = b->second;
  if (kept.fixes == 0) {  // a hint-only site: the other's footprint
    kept.lat = gone.lat;
    kept.lon = gone.lon;
    kept.alt = gone.alt;
    kept.extent_m = gone.extent_m;
    kept.reach_m = gone.reach_m;
    kept.cameras = gone.cameras;
  } else if (gone.fixes > 0) {
    join_footprints(kept, gone);
  }
  kept.fixes += gone.fixes;
  kept.unconfirmed.merge(gone.unconfirmed);
  for (const std::string& capture : gone.captures) {
    kept.captures.push_back(capture);
    capture_site_[capture] = into;
  }
  gone.captures.clear();
  gone.merged_into = into;
  return true;
}

std::string SiteDirectory::current(const std::string& id) const {
  std::lock_guard lock(mutex_);
  return current_locked(id);
}

std::string SiteDirectory::current_locked(const std::string& id) const {
  std::string at = id;
  for (int hops = 0; hops < 1000; ++hops) {  // a chain of merges
    auto it = sites_.find(at);
    if (it == sites_.end() || it->second.merged_into.empty()) return at;
    at = it->second.merged_into;
  }
  return at;
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

documents::Site SiteDirectory::to_document(const Site& site, double radius_m) {
  documents::Site doc;
  doc.name = site.name;
  doc.radius_m = radius_m;
  doc.fixes = site.fixes;
  doc.extent_m = site.extent_m;
  doc.reach_m = site.reach_m;
  doc.cameras = site.cameras;
  doc.captures = site.captures;
  doc.merged_into = site.merged_into;
  // A merged site is found by its id only, not by place.
  if (site.fixes > 0 && site.merged_into.empty())
    doc.centre = documents::GeoPoint{site.lat, site.lon, site.alt};
  return doc;
}

}  // namespace arscout::engine::service
