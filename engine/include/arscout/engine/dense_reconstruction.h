// The dense model of one site, grown one increment at a time alongside the
// sparse Reconstruction: a newly registered capture becomes a key view
// unless the views with depth maps observe nearly all it sees
// (DenseOptions::redundant_share) or their maps already measure nearly all
// of its picture (new_coverage_share), and a key view gets one plane-sweep
// depth map with its two best neighbours; depth maps are checked against
// each other (a depth survives only when another
// map agrees), and agreeing pixels are fused into a voxel-de-duplicated,
// coloured point cloud in the site frame. Earlier depth maps are never
// recomputed; when bundle adjustment moves cameras, the cloud is re-fused
// from the stored depth maps (cheap: no sweeping). The depth maps can be
// kept as bytes and adopted by a new process without sweeping again
// (serialize_depth_map, restore_depth_maps).
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "arscout/engine/dense.h"
#include "arscout/engine/model.h"
#include "arscout/engine/ply.h"

namespace arscout::engine {

// The last outlier pass (docs/dense.md, "Isolated points"): `points`
// without those that have fewer than `min_neighbours` others within
// `radius` (radius outlier removal, as PCL's RadiusOutlierRemoval), in
// their order; all of them when min_neighbours <= 0 (or there are none).
// Linear in the points
// (a hash grid of `radius` cells). The service runs it on each dense tile
// it stores, reconstruct on the cloud it writes. Throws
// std::invalid_argument for a radius <= 0.
std::vector<ColoredPoint> without_isolated_points(
    const std::vector<ColoredPoint>& points, double radius, int min_neighbours);

// Its defaults for a cloud of voxel edge `voxel`: a point needs 2 others
// within 2.5 voxels. A surface seen head-on fills about 20 voxels within
// that radius, its edge half as many; a floater standing alone none.
constexpr double kIsolatedRadiusVoxels = 2.5;
constexpr int kIsolatedMinNeighbours = 2;

struct DenseOptions {
  int long_side = 640;  // dense working resolution (long side, pixels)
  PlaneSweepOptions sweep;
  ConsistencyOptions consistency;
  int neighbours = 2;  // per key view: the paper's triplets
  // A neighbour's baseline, as the median angle between the two cameras'
  // rays to the sparse points they share: too small measures depth poorly,
  // too large matches poorly.
  double min_angle_deg = 2;
  double max_angle_deg = 35;
  // Each new depth map is checked against the maps of this many views that
  // share the most sparse points with it (both directions).
  int consistency_partners = 4;
  // Voxel edge in site units; 0 takes 1.5 pixel footprints at the median
  // depth of the first depth map (of the order of sweeping), derived again
  // at every fusion and adopted, with every map fused afresh, when it
  // differs from the cloud's by more than a tenth: it follows that map's
  // rescaling when the model changes scale, and the next map when the
  // first is withdrawn, but not each small change of scale a bundle
  // adjustment brings (a rebuild costs the whole site).
  double voxel_size = 0;
  // A camera that moved more than this share of a voxel (or turned by the
  // equivalent angle) since its depth map was fused triggers a re-fusion.
  double refuse_fraction = 0.25;
  // At most this many moved maps are re-fused per update, those that moved
  // farthest first; the rest keep their points where their cameras were
  // and are taken by later updates (DenseUpdate::deferred_maps). A global
  // adjustment of a 200-photo walk moved 40-80 maps per dense phase, and
  // re-fusing them all made the phase's cost grow with the site. 0: no
  // limit.
  int refuse_budget = 8;
  // Key views for new coverage: a newly registered view gets no depth map of
  // its own when at least this share of the sparse points it observes are
  // each observed by `redundant_observers` views that have one (the
  // keyframe redundancy rule of ORB-SLAM): what it sees is measured
  // already. Photos from one place looking one way (a scout standing
  // still) then cost one sweep; a walk's photos bring new points that few
  // views see and stay key views (bench/RESULTS.md: 397 of 400). Views
  // with fewer than 20 sparse points are always key views. Above 1 (or 0)
  // every registered view is a key view.
  double redundant_share = 0.9;
  int redundant_observers = 3;
  // New coverage: a newly registered view gets no depth map of its own
  // either when the maps of its consistency_partners best-connected key
  // views already measure at least this share of its picture where it sees
  // the scene (cells of a 16 x 12 grid holding its keypoints; depths of
  // those maps projected into it, two maps to a cell so that their depths
  // can agree). Off by default (0; above 1 too): the coarse grid does not
  // see what another angle adds, and on fountain-P11 at 0.8 it kept 3 of
  // 10 maps and a tenth of the points. On a long walk of photos 0.3-2 m
  // apart it halves the sweeps (bench/RESULTS.md), which a service that
  // must keep up with several scouts may want (`--dense-new-coverage`).
  double new_coverage_share = 0;
  // At most this many key views are swept per update, the earliest
  // registered first; the others wait for the next update
  // (DenseUpdate::deferred_views). An update publishes nothing before it
  // ends, so one that sweeps a backlog of 8 views at once shows the first
  // of them as late as the last. 0: no limit (the default; the service's
  // dense lanes sweep 2 per phase, docs/service.md).
  int sweep_budget = 0;
  // Keeping up under load: when more than this many registered views wait
  // for a sweep at the start of an update (views without a map, not judged
  // covered and not left without a neighbour last time, the one about to
  // be swept included), the update sweeps with catch_up_sweep(sweep):
  // planes twice as far apart, so a lane that fell behind a run of views
  // that all bring new coverage sweeps them in a little over half the time
  // (bench/dense_bench --auto --catch-up) and catches up. Depths keep their
  // sub-plane refinement; the map's format and fusion are the same. 0 or
  // less: never (-1, the default, lets the service's dense lanes use 2,
  // docs/service.md).
  int catch_up_backlog = -1;
  // The moved maps re-fused per update while the update also sweeps
  // (refuse_budget applies when it sweeps nothing): a new view's part of
  // the cloud goes before keeping old maps within a quarter voxel of their
  // cameras. Negative: refuse_budget always (the default).
  int refuse_budget_sweeping = -1;
};

// The sweep options of an update that catches up (catch_up_backlog):
// `sweep` with plane_step_px doubled and min_planes and max_planes halved.
PlaneSweepOptions catch_up_sweep(const PlaneSweepOptions& sweep);

struct DenseUpdate {
  std::vector<std::string> new_depth_maps;  // key views swept this time
  // Of those, the ones swept with catch_up_sweep: the update caught up.
  size_t caught_up_maps = 0;
  std::vector<std::string> skipped;  // registered, but no neighbour
  // Registered, not key views: others' maps cover what they see
  // (DenseOptions::redundant_share). Judged once, again after a withdrawal.
  std::vector<std::string> covered;
  bool refused = false;     // cloud rebuilt from all maps (or all moved)
  size_t refused_maps = 0;  // maps taken out and fused again: camera moved
  // Moved maps left for a later update (DenseOptions::refuse_budget): the
  // cloud still shows them where their cameras were.
  size_t deferred_maps = 0;
  // Key views left for a later update (DenseOptions::sweep_budget).
  size_t deferred_views = 0;
  size_t points = 0;  // in the fused cloud
  double sweep_s = 0;
  double filter_s = 0;
  double fusion_s = 0;
};

// The encoded photo (JPEG or PNG) of a capture, by id. Throws when missing.
using ImageSource = std::function<std::string(const std::string& id)>;

class DenseReconstruction {
 public:
  explicit DenseReconstruction(DenseOptions options = {});
  ~DenseReconstruction();
  DenseReconstruction(DenseReconstruction&&) noexcept;
  DenseReconstruction& operator=(DenseReconstruction&&) noexcept;

  // Brings the dense model up to `model`: sweeps the registered captures
  // that have no depth map yet and are key views, filters, fuses; drops the
  // maps of captures no longer in the model. `progress`, when set, is told
  // about each sweep.
  DenseUpdate update(
      const Model& model, const ImageSource& images,
      const std::function<void(const std::string&)>& progress = {});

  // Whether the next updates spread their sweeps and checks over OpenCV's
  // worker threads (PlaneSweepOptions::parallel and
  // ConsistencyOptions::parallel): a caller beside latency-critical work
  // keeps them on its own thread while that work is busy.
  void set_parallel(bool parallel);
  // The same, asked again as the work goes (before each sweep's group of
  // strips, PlaneSweepOptions::keep_parallel, and before each agreement
  // check): a caller beside work that may start at any moment. Empty:
  // parallel throughout.
  void set_parallel_while(std::function<bool()> while_true);

  std::vector<ColoredPoint> points() const;
  // The cloud region by region, for a reader that follows its changes
  // without reading it whole each time (the service's mesh tiles):
  //
  //   const uint64_t seen = dense.mark_cloud();  // ... later updates ...
  //   for (const CloudBlock& b : dense.cloud_blocks())
  //     if (b.changed > seen) reread(dense.points_in(lo_of(b), hi_of(b)));
  //
  // The blocks that held points since the cloud was fused afresh
  // (CloudBlock), cloud_block_edge() wide (16 voxels; 0 before the first
  // fusion); one that lost its last point is listed with 0 points and the
  // stamp of that change. A cloud fused afresh (a new voxel edge, a
  // rebuild) is all new blocks, stamped above every mark made before.
  std::vector<CloudBlock> cloud_blocks() const;
  double cloud_block_edge() const;
  // The stamp of the cloud's changes so far: later ones carry larger
  // stamps. 0 before the first fusion.
  std::uint64_t mark_cloud();
  // points() whose x and y lie in [lo, hi), in points()'s order; reads
  // only the blocks there.
  std::vector<ColoredPoint> points_in(const Eigen::Vector2d& lo,
                                      const Eigen::Vector2d& hi) const;
  // The stored maps, filtered: only pixels another map agrees with.
  std::vector<DepthMap> filtered_depth_maps() const;
  // As swept, before the consistency filter.
  const DepthMap* raw_depth_map(const std::string& id) const;
  // The key views as they are now: each one's photo at the working
  // resolution (undistorted, CV_8UC3, shared with the object: do not
  // write to it) and its depth map as fused (id, K and the model's current
  // R, t), in the order of sweeping. Texturing reads them (engine/mesh.h).
  struct KeyView {
    cv::Mat bgr;
    DepthMap map;
  };
  std::vector<KeyView> key_views() const;
  double voxel_size() const;

  // Persistence. A depth map is the one costly part of the dense state
  // (about a second of sweeping per view) and never changes once swept;
  // agreement masks and the cloud follow from the maps and the model in a
  // fraction of that. A service keeps each map's bytes as it appears and,
  // after a restart, restores them instead of sweeping again:
  //
  //   for (const auto& id : dense.depth_map_ids())
  //     store.put(dense.serialize_depth_map(id));  // once per map
  //   ... later, in a new process, with the sparse model restored:
  //   DenseReconstruction dense(options);
  //   dense.restore_depth_maps(store.all(), model, images);
  //   dense.update(model, images);  // sweeps only views without a map

  // Key views that have a depth map, in the order they were swept.
  std::vector<std::string> depth_map_ids() const;
  // Registered views judged not to be key views (DenseUpdate::covered, all
  // of them so far): the key views' maps measure what they see. Empty after
  // restore_depth_maps until the next update() judges them again.
  std::vector<std::string> covered_ids() const;
  // One key view's depth map as swept (depth, score, margin, K, R, t at
  // sweep time, the neighbours it was swept with, its place in the order of
  // sweeping), as self-describing bytes: a magic, a format version, the
  // size and a CRC-32, little-endian (the layout is in
  // src/dense/depth_map_io.h). The bytes never change once the map exists:
  // later poses from bundle adjustment are not in them, so a store
  // addressing blobs by content keeps each once. About 12 bytes a pixel
  // (0.9 MB at 320 x 240, 3.7 MB at 640 x 480). Throws
  // std::invalid_argument for an id without a map.
  std::string serialize_depth_map(const std::string& id) const;
  // Adopts depth maps serialized earlier (any order) and brings the state
  // up to `model` as update() would, without sweeping them again: poses are
  // taken from the model, agreement is checked again, the cloud is fused.
  // Maps of captures not registered in `model` are dropped, and so are the
  // maps held already of captures no longer in it; a map of a key view that
  // already has one here is ignored (maps do not change once swept). Views
  // of the model that have no map are NOT swept here (a later update()
  // sweeps them). `images` gives the key views' photos, for the points'
  // colours; DenseOptions::long_side must be the one the maps were swept
  // at.
  //
  // The maps take their order of sweeping back, and the voxel edge (when
  // DenseOptions::voxel_size is 0) follows from the first of them, as in
  // the running object. Each map is rescaled as update() does when the
  // model's scale around its camera differs from the sweep's (the ratio of
  // sparse point depths to map depths, SweptDepthMap in depth_map_io.h).
  // Agreement is checked from
  // scratch: every map against its consistency_partners best-connected maps of
  // `model`, both ways, as update() does after a withdrawal. The restored state
  // is therefore exactly that of an object that swept the same maps in one
  // update() of `model`; after a history of several increments the running
  // object had each map checked against the partners of its time, and a few
  // pixels can differ. The result reports no new depth maps, sweep_s 0 and
  // `refused` (the cloud is fused from all maps); fusion_s includes reading
  // the bytes and decoding the key views' photos.
  //
  // Throws std::runtime_error naming what is wrong for bytes that are not a
  // depth map of this format (wrong magic, version, truncated, sizes
  // inconsistent, checksum mismatch); std::invalid_argument for two maps of
  // one key view or a map whose size is not its photo's at long_side;
  // whatever `images` throws. The object is then unchanged.
  DenseUpdate restore_depth_maps(const std::vector<std::string>& maps,
                                 const Model& model, const ImageSource& images);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// update() again while moved maps were left for later
// (DenseUpdate::deferred_maps): the cloud then follows every camera, as a
// batch run wants at its end. Each further round only re-fuses (the model
// is the same), so it ends. The result is the first round's with the
// counts and times of all rounds added and the last round's points.
DenseUpdate update_until_settled(DenseReconstruction& dense, const Model& model,
                                 const ImageSource& images);

// One key view's depth map straight from a sparse model: the key and its
// best neighbours are decoded, undistorted and swept, without filtering.
// Throws std::invalid_argument when `key_id` is not registered or has no
// usable neighbour.
DepthMap compute_key_depth_map(const Model& model, const std::string& key_id,
                               const ImageSource& images,
                               const DenseOptions& options = {});

// A registered capture's photo as the dense stage sees it: decoded at
// `long_side`, undistorted; `K` receives the matching pinhole matrix.
// Throws std::invalid_argument when `id` is not registered.
cv::Mat load_undistorted(const Model& model, const std::string& id,
                         const ImageSource& images, int long_side,
                         Eigen::Matrix3d* K);

}  // namespace arscout::engine
