// A 3D Tiles 1.1 tileset of a site's point cloud (OGC 3D Tiles 1.1), so
// Cesium and other 3D Tiles clients show the site where it is: an octree
// of glTF point tiles with additive refinement (each tile holds a spread-out
// sample of its box; its children hold the rest), boxes and positions in
// the site's ENU frame, and a root transform from ENU to ECEF (WGS84).
#pragma once

#include <array>
#include <cstddef>
#include <string>
#include <vector>

#include "arscout/engine/geo.h"
#include "arscout/engine/ply.h"

namespace arscout::viewer {

struct PointTilesetOptions {
  std::size_t max_tile_points = 50000;  // a leaf holds at most this many
  int max_depth = 16;                   // then a leaf holds the rest
};

struct TilesetFile {
  std::string path;  // "tileset.json", "tiles/r04.glb", ...
  std::string bytes;
};

// The transform from the site's ENU frame at `origin` to ECEF (WGS84),
// column-major, as a tileset's root "transform" holds it.
std::array<double, 16> enu_to_ecef_transform(const engine::Geodetic& origin);

// tileset.json first, then one .glb per tile. Tile names spell their path
// from the root ("r", then one octant digit per level). A tile's geometric
// error is the spacing of its sample (its box's diagonal over the sample
// grid's cells per axis); leaves have 0. Throws std::invalid_argument for
// an empty cloud.
std::vector<TilesetFile> build_point_tileset(
    const std::vector<engine::ColoredPoint>& enu_points,
    const engine::Geodetic& origin, const PointTilesetOptions& options = {});

}  // namespace arscout::viewer
