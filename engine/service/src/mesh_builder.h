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
  // A mesh tile is a column this many grid steps wide (256 dense voxels,
  // half a dense tile's edge). Narrower tiles keep the first tile of a
  // phase, made whatever the budget, inside it (the block walk's figures
  // in bench/RESULTS.md are for 48 steps), but at 48 steps neighbouring
  // tiles did not meet edge to edge in
  // EngineWorker.TheDenseLanePublishesATexturedSurfacePerTile: to find
  // before narrowing them.
  int tile_cells = 128;
  // Seconds of tile making per call, after the first tile: the tiles
  // whose points changed are made in order of need (never made first, then
  // by how much their point count changed) while the next one's estimated
  // cost fits; the others keep their published surface and are left for a
  // later call (MeshBuild::left). 0: every changed tile.
  double budget_seconds = 0;
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
  double seconds = 0;
};

// The mesh tiles for `cloud` (the fused points, site frame): columns of
// MeshBuildOptions::tile_cells grid steps named "ix_iy". The grid step is
// that of `published` while 2 * `voxel` stays within a factor 1.25 of it
// (the surface's grid does not move as the dense voxel drifts), else
// 2 * voxel (SurfaceOptions::cell), and then every published tile is
// dropped and made again. Tiles of `published` whose input hash is
// unchanged are kept as they are, the others made (within the budget) and
// stored through `put_blob` (which returns the blob's name).
// Deterministic for the same inputs when the budget is 0.
MeshBuild update_mesh_tiles(
    const std::vector<ColoredPoint>& cloud, double voxel,
    const std::vector<MeshTileEntry>& published,
    const std::vector<DenseReconstruction::KeyView>& views,
    const std::function<std::string(const std::string& bytes)>& put_blob,
    const MeshBuildOptions& options = {});

}  // namespace arscout::engine::service
