// Which site a capture belongs to: the nearest site whose footprint comes
// within the radius of the capture's GPS fix, else a new site; captures
// without a fix go by their scout's site hint. A site's footprint is a disc
// around its centre, the mean of its captures' fixes, as wide as its
// farthest capture ("extent"): a site within the radius of its centre
// would split a long street walk into pieces, one every radius or so.
//
// Site ids are derived from the capture that founds the site ("s-" and its
// id) or from the hint ("h-" and the hint), so placing the same capture
// again after a crash, before its site was ever stored, gives the same id.
//
// Two sites meet when a capture's fix lies within the radius of both
// footprints: the capture goes to the nearer, and the worker merges the
// other into it (merge()); a merged site keeps its id, says where it went
// (`merged_into`) and takes no captures again.
// Thread-safe.
#pragma once

#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "arscout/documents/site.h"
#include "arscout/engine/geo.h"

namespace arscout::engine::service {

using Json = nlohmann::json;

struct Site {
  std::string id;
  std::string name;  // the hint it was founded by, or its id
  double lat = 0, lon = 0, alt = 0;
  int fixes = 0;  // captures with GPS that moved the centre
  // An upper bound of the distance from the centre to its farthest fix,
  // metres (kept as the centre moves without storing every fix).
  double extent_m = 0;
  std::vector<std::string> captures;  // in order of placement
  std::string merged_into;            // set once it grew into another
};

class SiteDirectory {
 public:
  explicit SiteDirectory(double radius_m) : radius_m_(radius_m) {}

  // Adopts the stored sites (the attrs of /sites/* documents, keyed by id).
  // Throws documents::DocumentError for a site whose captures are not a
  // list of ids.
  void load(const std::map<std::string, Json>& sites);

  // The site `capture` was placed in, if any.
  std::optional<std::string> site_of(const std::string& capture) const;

  // Places a new capture and returns its site's id; the same id again for
  // a capture placed before. Returns nullopt when it has neither a fix nor
  // a hint (nothing to place it by).
  std::optional<std::string> place(const std::string& capture,
                                   const std::optional<GeoFix>& fix,
                                   const std::string& hint);

  // The live sites other than `site` that the fix lies within the radius
  // of (they meet `site` there), nearest first.
  std::vector<std::string> meeting(const std::string& site,
                                   const GeoFix& fix) const;

  // Moves `from`'s captures into `into` (the centre, the fixes and the
  // extent follow) and marks `from` merged into it. False, changing
  // nothing, when either is unknown or merged already, or they are one.
  bool merge(const std::string& from, const std::string& into);
  // Where a site's captures are now: the site it was merged into (through
  // later merges), or itself.
  std::string current(const std::string& id) const;

  // A copy of the site, or nullopt.
  std::optional<Site> site(const std::string& id) const;
  std::vector<Site> sites() const;

  // The /sites/{id} document's form, without the engine's counters
  // (registered, model_version, state, engine).
  static documents::Site to_document(const Site& site, double radius_m);
  double radius_m() const { return radius_m_; }

 private:
  static std::string sanitise(const std::string& text);

  double radius_m_;
  mutable std::mutex mutex_;
  std::map<std::string, Site> sites_;
  std::map<std::string, std::string> capture_site_;
};

}  // namespace arscout::engine::service
