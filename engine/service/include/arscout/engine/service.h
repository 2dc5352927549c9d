// The engine service (the paper's whole loop): a worker subscribed to the
// store's change feed places every new capture in a site, reconstructs that
// site incrementally and writes the model back, where every subscriber sees
// it.
//
//   auto store = db::Store::open("sqlite:arscout.db");
//   EngineWorker worker(*store, {});
//   worker.start();          // follows /captures/* from its checkpoint
//   ...
//   worker.stop();
//
// Documents it reads: /captures/{id} (kind "capture", written by the API),
// /cameras/{id}, /sites/*. Documents it writes, per increment and in one
// atomic batch (docs/service.md gives every attribute):
//
//   /sites/{id}              the site: name, centre (attrs.gps), radius,
//                            captures, registered count, model version
//   /sites/{id}/model        the model (a new version per increment): ENU
//                            origin, cameras, poses, statistics, timings;
//                            blob "sparse" (binary PLY), the dense cloud's
//                            tiles (attrs.dense_tiles)
//   /sites/{id}/dense/{t}    one tile of the dense cloud (blob "points",
//                            binary PLY), rewritten when its points change
//   /sites/{id}/engine       the engine's state (blob "state"), so that a
//                            restarted worker continues without recomputing
//   /sites/{id}/depth/{c}    one swept depth map per key view (blob "map")
//   /captures/{id}           patched: site, status (registered | rejected,
//                            or stored while the site waits for more
//                            captures), status_reason
//   /checkpoints/{name}      the feed position: every capture change at or
//                            before it is in a committed model
//
// Delivery is at least once: a change seen again after a crash finds its
// capture already in the restored state and is skipped.
//
// Several workers can follow one database: every worker places every
// capture (placing is a pure function of the feed, so they agree), but a
// site is reconstructed only by the worker holding its lease; the others
// keep its work until they see it committed, and take the site over when
// its holder's lease expires.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "arscout/engine/dense_reconstruction.h"
#include "arscout/engine/ply.h"
#include "arscout/engine/reconstruction.h"

namespace arscout::db {
class Store;
struct Document;
}  // namespace arscout::db

namespace arscout::engine {

struct WorkerOptions {
  // Names the feed checkpoint (/checkpoints/{name}) and the writes' author.
  std::string name = "engine";
  // A capture joins the nearest site whose footprint (its registered
  // cameras) is within this distance of its GPS fix, else founds a new site.
  double site_radius_m = 50;
  // Captures one increment of a site takes at most, in turns between the
  // scouts that sent them (oldest first within each): one scout's burst
  // delays another's photo by at most this many.
  int increment_captures = 4;
  // Photos decoded and described ahead of their increments, on a thread of
  // their own, at most this many held at once (0: each inside its
  // increment). Deterministic runs prepare none: the same features, but
  // their timing would follow the machine.
  int prepare_ahead = 16;
  bool dense = true;
  // A textured surface per mesh tile, remade in the dense lane after each
  // dense phase where its points changed and published with the model
  // (docs/mesh.md). Needs `dense`.
  bool mesh = false;
  // Seconds of mesh tile making per dense phase (after the first tile):
  // the tiles in most need first, the others stay as published until a
  // later phase, which the lane runs even with no photo left to sweep.
  // Bounds what the mesh adds to the dense lane. 0: every changed tile
  // each phase (and in deterministic runs).
  double mesh_budget_seconds = 1.0;
  ReconstructionOptions reconstruction;
  DenseOptions dense_options;
  // Sites reconstructed at the same time; one site's work never waits for
  // another's beyond this.
  int site_threads = 2;
  // Several workers may share one database (docs/service.md, "Several
  // workers"): each holds a lease per site it reconstructs and renews it
  // every third of this; a worker that stops renewing (it died) loses its
  // sites to the others once this has passed. Names must differ.
  std::chrono::milliseconds lease_ttl{15000};
  // How long a site's committed work may stay out of its saved engine
  // state while photos keep coming (docs/service.md, "Crashes and
  // restarts"): the state, ~90 KB a registered photo, is written at most
  // this often then, and whenever the site is quiet for a second. A crash
  // redoes what was unsaved. 0: at every increment (and always in
  // deterministic runs).
  std::chrono::milliseconds state_interval{30000};
  // How long a site with unsaved work must have committed nothing before
  // its state is written as a quiet site's (the "quiet second" above; the
  // worker looks at least every second, so the write comes within a
  // second after). Work stays in flight until then, so wait_idle() waits
  // for it too.
  std::chrono::milliseconds quiet_save_after{1000};
  // A site publishes a version from its global refinement (one that adds
  // no capture) at most this often: each round is a model version, and a
  // refinement that resumes after every photo published one every second
  // or two (65 versions for 8 photos), each with its blobs. A round due
  // sooner waits for the interval (the worker is not idle meanwhile); a
  // merge or a loop closure (SiteJob::refinement_urgent) does not wait,
  // nor do deterministic runs. 0: no bound.
  std::chrono::milliseconds refinement_interval{0};
  // A site stores its dense cloud's changed tiles at most this often while
  // its dense lane has work left over (views to sweep, moved maps to
  // re-fuse): every store of a tile is a new blob of the whole tile, and a
  // lane that runs behind the photos rewrote the same tiles every few
  // seconds (5 MB/s of garbage on a 400-photo walk). The lane's last phase,
  // with nothing left over, always stores them, as do deterministic runs.
  // The depth maps are stored by every phase either way. 0: every phase.
  std::chrono::milliseconds dense_tile_interval{0};
  // Told one line per increment and per placed capture; empty: silent.
  std::function<void(const std::string&)> progress;
};

struct WorkerStats {
  std::int64_t changes_seen = 0;
  std::int64_t captures_placed = 0;
  std::int64_t increments = 0;    // committed model versions, all sites
  std::int64_t checkpoint = 0;    // last feed position saved
  std::int64_t failures = 0;      // increments that failed (retried later)
  std::int64_t sites_held = 0;    // site leases held now
  std::int64_t sites_taken = 0;   // site leases claimed, all time
  std::int64_t sites_merged = 0;  // sites that grew into another, all time
  std::int64_t sites = 0;         // sites this worker knows
  // Captures placed and not yet in a committed increment: queued for their
  // site (or deferred while another worker holds it), or being added.
  std::int64_t captures_waiting = 0;
  // Photos prepared ahead of their increments (WorkerOptions::
  // prepare_ahead): made, used by an increment, and found still queued by
  // their increment, which then prepared them itself (the preparer is
  // behind).
  std::int64_t photos_prepared = 0;
  std::int64_t photos_prepared_used = 0;
  std::int64_t photos_prepared_late = 0;
};

class EngineWorker {
 public:
  EngineWorker(db::Store& store, WorkerOptions options);
  ~EngineWorker();  // stops
  EngineWorker(const EngineWorker&) = delete;
  EngineWorker& operator=(const EngineWorker&) = delete;

  // Loads the sites, then follows /captures/* from the checkpoint on
  // threads of its own. Throws db::StoreError when the store cannot be read.
  void start();
  // Finishes the increments under way (committing them), drops queued work
  // (the checkpoint has not passed it: a restart redoes it) and returns.
  void stop();
  // Blocks until every change committed before the call has been placed
  // and every increment it caused has committed, or the timeout passes.
  // True when idle.
  bool wait_idle(std::chrono::milliseconds timeout);
  WorkerStats stats() const;
  // stats() and the phases' durations (sparse increments, dense phases,
  // refinements) as histograms, with how far the feed's head is past the
  // checkpoint, in the Prometheus text format (docs/service.md, "Health
  // and metrics"). Reads the store's head; without it the lag is left out.
  std::string metrics() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// The reconstruction of `site` as the engine last committed it: the state
// blob of /sites/{site}/engine with each capture's features from
// /sites/{site}/features/{capture} (docs/service.md); std::nullopt when the
// engine has not written one. `stored_features`, when given, receives the
// captures whose features are stored. Throws std::runtime_error when the
// state is damaged or a capture's features are missing, db::StoreError when
// the store cannot be read. The viewer reads the full model (keypoints and
// tracks) through it, the engine service restores a site with it.
std::optional<Reconstruction> load_site_reconstruction(
    db::Store& store, const std::string& site,
    ReconstructionOptions options = {},
    std::set<std::string>* stored_features = nullptr);

// The dense cloud a model document (/sites/{id}/model) publishes: the PLY
// blobs of its tiles (attrs.dense_tiles) in tile order, or the one "dense"
// blob of a model written before tiles; empty before the first dense
// phase.
std::vector<std::string> dense_cloud_blobs(const db::Document& model);
// Their points (`blobs` as dense_cloud_blobs gave them), concatenated.
// Throws db::StoreError(kNotFound) when a blob is gone (collected after a
// later version replaced its tile: read the model again) and
// std::runtime_error when one is not a PLY.
std::vector<ColoredPoint> load_dense_cloud(
    db::Store& store, const std::vector<std::string>& blobs);

// The surface a model document publishes (docs/mesh.md): per mesh tile
// (a column of the surface's grid), its levels of detail as GLB blobs
// (engine/mesh.h encode_glb), finest first. The attribute "mesh_tiles" is
// an array of {tile, hash (decimal string: of the points it was made
// from), points, cell, levels: [{blob, triangles, error}]}, by tile name;
// empty before the first mesh phase. A tile whose points made no surface
// has no levels (it is kept so that it is not made again until its points
// change). A tile's surface may be older than the cloud (its hash is then
// not that of its points now): the mesh phase has a time budget.
struct MeshTileLevel {
  std::string blob;  // SHA-256 of its GLB
  std::size_t triangles = 0;
  double geometric_error = 0;  // site units (metres once geo-registered)
};
struct MeshTileEntry {
  std::string tile;        // "ix_iy": its column on the mesh grid
  std::uint64_t hash = 0;  // of the points it was made from
  std::size_t points = 0;  // how many
  double cell = 0;         // the surface's grid step it was made on
  std::vector<MeshTileLevel> levels;
};
std::vector<MeshTileEntry> mesh_tiles_of(const db::Document& model);
nlohmann::json mesh_tiles_json(const std::vector<MeshTileEntry>& tiles);

}  // namespace arscout::engine
