// The site's surface kept up with its dense cloud, tile by tile
// (docs/mesh.md): a tile's mesh is made again only when the points it is
// made from changed (its column's and those within the blending margin of
// its border), from the whole cloud's points there, textured from the key
// views that see it, simplified into levels of detail and stored as one
// GLB blob per level. Runs in the dense lane after the tiles it follows.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "arscout/engine/dense_reconstruction.h"
#include "arscout/engine/mesh.h"
#include "arscout/engine/service.h"

namespace arscout::engine::service {

struct MeshBuildOptions {
  SurfaceOptions surface;
  // The occlusion z-buffer at the key views' working resolution (the dense
  // lane's 640 px long side): finer would test depths the maps lack.
  TextureOptions texture = {.raster_long_side = 640};
  int levels = 3;         // of detail, the finest included
  int max_views = 8;      // nearest key views that see a tile texture it
  int jpeg_quality = 85;  // of the atlases
  // A mesh tile is a column this many grid steps wide (96 dense voxels,
  // 1.5 m at the block walk's 1.6 cm). Narrow enough that the first tile of
  // a phase, made whatever the budget, stays inside it (a tile's cost
  // follows its points: about 0.5 s for 120,000 on 2 cores).
  int tile_cells = 48;
  // Seconds of tile making per call, after the first tile: the tiles
  // whose points changed are made in order of need (never made first, then
  // by how much their point count changed) while the next one's estimated
  // cost fits; the others keep their published surface and are left for a
  // later call (MeshBuild::left). 0: every changed tile.
  double budget_seconds = 0;
};

// The cloud as the mesh reads it: the blocks of ground that hold points or
// did (CloudBlock::points 0), each stamped with its last change, and the
// points of a region (DenseReconstruction's cloud_blocks, cloud_block_edge
// and points_in).
class MeshCloud {
 public:
  virtual ~MeshCloud() = default;
  virtual double block_edge() const = 0;
  virtual std::vector<CloudBlock> blocks() const = 0;
  // The points with x and y in [lo, hi), in the cloud's order.
  virtual std::vector<ColoredPoint> points_in(
      const Eigen::Vector2d& lo, const Eigen::Vector2d& hi) const = 0;
};

// A dense reconstruction's cloud as a MeshCloud (held by reference).
class DenseMeshCloud : public MeshCloud {
 public:
  explicit DenseMeshCloud(const DenseReconstruction& dense) : dense_(dense) {}
  double block_edge() const override { return dense_.cloud_block_edge(); }
  std::vector<CloudBlock> blocks() const override {
    return dense_.cloud_blocks();
  }
  std::vector<ColoredPoint> points_in(
      const Eigen::Vector2d& lo, const Eigen::Vector2d& hi) const override {
    return dense_.points_in(lo, hi);
  }

 private:
  const DenseReconstruction& dense_;
};

// A column a call left stale, as it read it: the hash and count of the
// points its surface reads.
struct StaleColumn {
  long long ix = 0, iy = 0;
  std::uint64_t hash = 0;
  std::size_t points = 0;
};

// What a call tells the next one about the same published tiles: the
// cloud's stamp when it read it (DenseReconstruction::mark_cloud) and the
// columns it left stale. The next call reads again only the columns near a
// block changed since; the columns left and unchanged keep their place in
// the queue from what this call read. A call's cost thus follows what
// changed and what it makes, not the whole cloud nor the backlog. The
// default (stamp 0) reads every column, as after a restart.
struct MeshCursor {
  std::uint64_t seen = 0;
  double cell = 0;  // the grid step it was for
  std::vector<StaleColumn> left;
};

struct MeshBuild {
  // Every column with points, in name order: made now, kept, or left
  // stale (its published surface, with the hash it was made from). A
  // column whose points made no surface has no levels (kept so that it is
  // not made again while its points stay the same).
  std::vector<MeshTileEntry> tiles;
  std::size_t remade = 0;     // tiles made this time
  std::size_t left = 0;       // tiles whose points changed, left for later
  std::size_t left_new = 0;   // of them, never made (no surface shown yet)
  std::size_t triangles = 0;  // in the finest levels of all tiles
  std::size_t looked_at = 0;  // columns whose points were read
  double seconds = 0;
  MeshCursor cursor;  // for the next call on these tiles
};

// The mesh tiles for `cloud` (the fused points, site frame): columns of
// MeshBuildOptions::tile_cells grid steps named "ix_iy". The grid step is
// that of `published` while 2 * `voxel` stays within a factor 1.25 of it
// (the surface's grid does not move as the dense voxel drifts), else
// 2 * voxel (SurfaceOptions::cell), and then every published tile is
// dropped and made again. A column is looked at when `since` (the cursor
// the call that made `published` returned) left it stale or a block
// within its reach changed after `since.seen`, or always when the grid
// step is not the cursor's; its points are then hashed, and a tile of
// `published` whose input hash is unchanged is kept as it is. The others
// are made (within the budget) and stored through `put_blob` (which
// returns the blob's name). The cursor returned carries `now` (the stamp
// of the cloud as read: mark_cloud before the call). Deterministic for
// the same inputs when the budget is 0.
MeshBuild update_mesh_tiles(
    const MeshCloud& cloud, std::uint64_t now, double voxel,
    const std::vector<MeshTileEntry>& published, const MeshCursor& since,
    const std::vector<DenseReconstruction::KeyView>& views,
    const std::function<std::string(const std::string& bytes)>& put_blob,
    const MeshBuildOptions& options = {});

// The same for a cloud given whole, every column looked at.
MeshBuild update_mesh_tiles(
    const std::vector<ColoredPoint>& cloud, double voxel,
    const std::vector<MeshTileEntry>& published,
    const std::vector<DenseReconstruction::KeyView>& views,
    const std::function<std::string(const std::string& bytes)>& put_blob,
    const MeshBuildOptions& options = {});

}  // namespace arscout::engine::service
