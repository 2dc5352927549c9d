// Which site a capture belongs to: the nearest site whose footprint comes
// within the radius of the capture's GPS fix, else a new site; captures
// without a fix go by their scout's site hint.
//
// A site's footprint follows its registered cameras, not raw fixes: a disc
// around their mean, as wide as the farthest ("extent"); before any camera
// registers, the founding capture's fix. Fixes of captures placed but not
// yet registered widen the disc ("reach") by at most kUnconfirmedReach
// radii beyond the extent, and only until the engine has processed them
// (follow()), so a walk uploaded faster than the engine keeps to one site
// while a stream of fixes walking away (junk, or a hostile client) founds
// new sites every few radii instead of dragging one kilometres away.
// Placement therefore depends on how far the engine has got, for captures
// near the edge of the reach.
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
#include "arscout/engine/reconstruction.h"

namespace arscout::engine::service {

using Json = nlohmann::json;

// How far fixes of captures not yet registered may widen a footprint, in
// site radii beyond its extent.
inline constexpr double kUnconfirmedReach = 4;

// Where a site's registered cameras are: their mean and the distance from
// it to the farthest, metres; cameras == 0 when none has a position.
struct Footprint {
  double lat = 0, lon = 0, alt = 0;
  double extent_m = 0;
  int cameras = 0;
};

// The footprint of a model's registered cameras (those with a geodetic
// position: the model is geo-registered).
Footprint registered_footprint(const Model& model);

struct Site {
  std::string id;
  std::string name;  // the hint it was founded by, or its id
  double lat = 0, lon = 0, alt = 0;
  int fixes = 0;                      // captures placed by their fix
  double extent_m = 0;                // the cameras' footprint (see above)
  double reach_m = 0;                 // >= extent_m: with unconfirmed fixes
  int cameras = 0;                    // registered cameras the centre follows
  std::vector<std::string> captures;  // in order of placement
  std::string merged_into;            // set once it grew into another
  // Fixes of captures placed here that the engine has not processed yet.
  std::map<std::string, GeoFix> unconfirmed;
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
  // a hint (nothing to place it by). A hint names the site `h-{hint}`
  // (followed through merges; a rename does not change it). A site this
  // capture founds by its fix is named `name` ("" : its id).
  std::optional<std::string> place(const std::string& capture,
                                   const std::optional<GeoFix>& fix,
                                   const std::string& hint,
                                   const std::string& name = "");

  // Places a capture with no fix in site `id` (followed through merges):
  // where its scout's photos taken about the same time went
  // (scout_trails.h). The same site again for a capture placed before;
  // nullopt when `id` is unknown.
  std::optional<std::string> place_in(const std::string& capture,
                                      const std::string& id);

  // The engine processed `settled` (registered or not) and site `id`'s
  // registered cameras make `cameras`: the centre and extent follow them
  // (unless there are none), and the reach covers the fixes still
  // unconfirmed. False for an unknown site.
  bool follow(const std::string& id, const Footprint& cameras,
              const std::vector<std::string>& settled);

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
  // current() with the mutex held.
  std::string current_locked(const std::string& id) const;
  // `kept`'s footprint becomes one disc over both.
  static void join_footprints(Site& kept, const Site& gone);
  // Widens the reach to cover `fix`, within its bound.
  void widen(Site& site, const GeoFix& fix) const;

  double radius_m_;
  mutable std::mutex mutex_;
  std::map<std::string, Site> sites_;
  std::map<std::string, std::string> capture_site_;
};

}  // namespace arscout::engine::service
