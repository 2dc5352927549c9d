// The published dense cloud as tiles: square columns of the site frame, each
// stored as its own PLY blob under /sites/{id}/dense/{tile}. A dense phase
// that adds one key view changes a few tiles, so it stores those few rather
// than the whole cloud (1.4 s for 8 million points on one blob, growing
// with the site; bench/RESULTS.md).
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "arscout/engine/ply.h"

namespace arscout::engine::service {

struct DenseTile {
  std::string blob;        // SHA-256 of its PLY
  std::uint64_t hash = 0;  // of its fused points, in any order
  std::size_t fused = 0;   // fused points, before the outlier pass
  std::size_t points = 0;  // in its PLY
};

// By tile name ("ix_iy": the column's integer coordinates).
using DenseTiles = std::map<std::string, DenseTile>;

// A tile's edge for a cloud of voxel edge `voxel`: 512 voxels (about 8.6 m
// at the block walk's 1.7 cm), so a tile's PLY stays a few megabytes.
double dense_tile_size(double voxel);

// The most tiles a cloud is split into: each is an entry of the model
// document's `dense_tiles`, and the document must stay within the store's
// attribute limit (1 MiB) however far a cloud spreads (stray points, a
// component placed by its fixes alone).
constexpr std::size_t kMaxDenseTiles = 1024;

// Splits `points` into tiles of edge `size` (doubled until there are at
// most kMaxDenseTiles) and stores (put_blob) the PLY of each tile whose
// points differ from its entry in `published`, without its isolated points
// (without_isolated_points with `isolated_radius` and
// `isolated_min_neighbours`, within the tile; 0 neighbours keeps them);
// the others keep their blob. Returns every non-empty tile; `edge_used`,
// when given, receives the tiles' edge (`size`, doubled as it was).
DenseTiles store_dense_tiles(
    const std::vector<ColoredPoint>& points, double size,
    const DenseTiles& published,
    const std::function<std::string(const std::string& bytes)>& put_blob,
    double isolated_radius = 0, int isolated_min_neighbours = 0,
    double* edge_used = nullptr);

// A tile's name: its column's integer coordinates, "ix_iy".
std::string dense_tile_name(long long ix, long long iy);

// A fused point's position, colour and support mixed into 64 bits: summed
// over a set of points it identifies the set in any order.
std::uint64_t dense_point_hash(const ColoredPoint& p);

// The model document's "dense_tiles" attribute (docs/service.md): an array
// of {tile, blob, points, fused, hash (decimal string)}, by tile name.
nlohmann::json dense_tiles_json(const DenseTiles& tiles);
// Its inverse (a tile without a readable hash is stored again by the next
// dense phase).
DenseTiles dense_tiles_from_json(const nlohmann::json& attr);

}  // namespace arscout::engine::service
