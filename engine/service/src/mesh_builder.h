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
  TextureOptions texture;
  int levels = 3;         // of detail, the finest included
  int max_views = 16;     // nearest key views that see a tile texture it
  int jpeg_quality = 85;  // of the atlases
};

struct MeshBuild {
  std::vector<MeshTileEntry> tiles;  // every tile with a surface
  std::size_t remade = 0;            // tiles made again this time
  std::size_t triangles = 0;         // in the finest levels of all tiles
  double seconds = 0;
};

// The mesh tiles for `cloud` (the fused points, site frame) in tiles of
// edge `edge` named as the dense tiles are ("ix_iy"), with grid step from
// `voxel` (SurfaceOptions::cell); those of `published` whose input hash is
// unchanged are kept as they are, the others made and stored through
// `put_blob` (which returns the blob's name). Deterministic for the same
// inputs.
MeshBuild update_mesh_tiles(
    const std::vector<ColoredPoint>& cloud, double edge, double voxel,
    const std::vector<MeshTileEntry>& published,
    const std::vector<DenseReconstruction::KeyView>& views,
    const std::function<std::string(const std::string& bytes)>& put_blob,
    const MeshBuildOptions& options = {});

}  // namespace arscout::engine::service
