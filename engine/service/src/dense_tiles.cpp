#include "dense_tiles.h"

#include "arscout/engine/dense_reconstruction.h"

#include "arscout/db/document.h"
#include "arscout/db/store.h"
#include "arscout/engine/service.h"

#include <cmath>
#include <cstring>
#include <set>
#include <unordered_map>
#include <utility>

namespace arscout::engine::service {
namespace {

using TileKey = std::pair<long long, long long>;

// Clamped: a point far outside any site (or not finite) must not make the
// conversion undefined; it lands in an edge tile.
long long tile_index(float coordinate, double size) {
  constexpr double kLimit = 1e9;
  const double index = std::floor(coordinate / size);
  if (!(index > -kLimit)) return static_cast<long long>(-kLimit);
  if (!(index < kLimit)) return static_cast<long long>(kLimit);
  return static_cast<long long>(index);
}

TileKey tile_key(const ColoredPoint& p, double size) {
  return {tile_index(p.x, size), tile_index(p.y, size)};
}

std::string tile_name(const TileKey& key) {
  return dense_tile_name(key.first, key.second);
}

struct TileKeyHash {
  std::size_t operator()(const TileKey& k) const {
    return std::hash<unsigned long long>()(
        static_cast<unsigned long long>(k.first) * 1000003ULL ^
        static_cast<unsigned long long>(k.second));
  }
};

// A point's position, colour and support mixed into 64 bits (splitmix64's
// finaliser), summed over a tile: the sum does not depend on the points'
// order, which the voxel cloud does not keep. The normal and the score are
// left out: they change only with the samples in their voxel, which move
// the mean position too.
std::uint64_t point_hash(const ColoredPoint& p) {
  std::uint64_t a = 0, b = 0;
  std::memcpy(&a, &p.x, sizeof(float));
  std::memcpy(reinterpret_cast<char*>(&a) + 4, &p.y, sizeof(float));
  std::memcpy(&b, &p.z, sizeof(float));
  b |= static_cast<std::uint64_t>(p.r) << 32 |
       static_cast<std::uint64_t>(p.g) << 40 |
       static_cast<std::uint64_t>(p.b) << 48 |
       static_cast<std::uint64_t>(p.support) << 56;
  std::uint64_t z = a * 0x9E3779B97F4A7C15ull ^ b;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

// The points' tiles: each point's index into `keys`, the distinct tiles.
struct TileAssignment {
  std::vector<TileKey> keys;
  std::vector<std::uint32_t> tile_of;
};

// Numbers distinct keys in order of first appearance, into `keys`.
class KeyNumbering {
 public:
  explicit KeyNumbering(std::vector<TileKey>& keys) : keys_(keys) {}
  std::uint32_t operator()(const TileKey& key) {
    auto [it, added] =
        index_.emplace(key, static_cast<std::uint32_t>(keys_.size()));
    if (added) keys_.push_back(key);
    return it->second;
  }

 private:
  std::vector<TileKey>& keys_;
  std::unordered_map<TileKey, std::uint32_t, TileKeyHash> index_;
};

TileAssignment assign_tiles(const std::vector<ColoredPoint>& points,
                            double size) {
  TileAssignment a;
  KeyNumbering number(a.keys);
  a.tile_of.resize(points.size());
  for (std::size_t i = 0; i < points.size(); ++i)
    a.tile_of[i] = number(tile_key(points[i], size));
  return a;
}

// Tiles `halvings` times coarser (each 2^halvings tiles on a side): an
// index divided by 2^k, rounded down, is the index at a 2^k times larger
// edge (>> on a negative integer rounds down too).
TileAssignment coarsen(const TileAssignment& fine, int halvings) {
  TileAssignment a;
  KeyNumbering number(a.keys);
  std::vector<std::uint32_t> coarse_of;
  for (const TileKey& key : fine.keys)
    coarse_of.push_back(
        number({key.first >> halvings, key.second >> halvings}));
  a.tile_of.resize(fine.tile_of.size());
  for (std::size_t i = 0; i < fine.tile_of.size(); ++i)
    a.tile_of[i] = coarse_of[fine.tile_of[i]];
  return a;
}

// How many times the edge must double for `keys` to fall into at most
// kMaxDenseTiles tiles.
int halvings_for(const std::vector<TileKey>& keys) {
  for (int halvings = 0;; ++halvings) {
    std::set<TileKey> coarse;
    for (const TileKey& key : keys) {
      coarse.insert({key.first >> halvings, key.second >> halvings});
      if (coarse.size() > kMaxDenseTiles) break;
    }
    if (coarse.size() <= kMaxDenseTiles) return halvings;
  }
}

}  // namespace

double dense_tile_size(double voxel) { return 512 * voxel; }

std::string dense_tile_name(long long ix, long long iy) {
  return std::to_string(ix) + "_" + std::to_string(iy);
}

std::uint64_t dense_point_hash(const ColoredPoint& p) { return point_hash(p); }

DenseTiles store_dense_tiles(
    const std::vector<ColoredPoint>& points, double size,
    const DenseTiles& published,
    const std::function<std::string(const std::string& bytes)>& put_blob,
    double isolated_radius, int isolated_min_neighbours, double* edge_used) {
  // One pass for each point's tile, coarser while there are too many; then
  // the tiles' hashes; the points are gathered only for the tiles that
  // changed.
  TileAssignment assignment = assign_tiles(points, size);
  int halvings = 0;
  if (assignment.keys.size() > kMaxDenseTiles) {
    halvings = halvings_for(assignment.keys);
    assignment = coarsen(assignment, halvings);
  }
  if (edge_used) *edge_used = std::ldexp(size, halvings);
  const std::vector<std::uint32_t>& tile_of = assignment.tile_of;
  std::vector<DenseTile> found(assignment.keys.size());
  std::vector<std::string> names;
  for (const TileKey& key : assignment.keys) names.push_back(tile_name(key));
  for (std::size_t i = 0; i < points.size(); ++i) {
    DenseTile& tile = found[tile_of[i]];
    tile.hash += point_hash(points[i]);
    ++tile.fused;
  }
  std::vector<std::vector<ColoredPoint>> changed(found.size());
  std::vector<bool> is_changed(found.size(), false);
  for (std::size_t t = 0; t < found.size(); ++t) {
    const auto was = published.find(names[t]);
    if (was != published.end() && was->second.hash == found[t].hash &&
        was->second.fused == found[t].fused && !was->second.blob.empty()) {
      found[t].blob = was->second.blob;
      found[t].points = was->second.points;
    } else {
      is_changed[t] = true;
    }
  }
  for (std::size_t i = 0; i < points.size(); ++i)
    if (is_changed[tile_of[i]]) changed[tile_of[i]].push_back(points[i]);
  DenseTiles tiles;
  for (std::size_t t = 0; t < found.size(); ++t) {
    if (is_changed[t]) {
      const std::vector<ColoredPoint> kept = without_isolated_points(
          changed[t], isolated_radius, isolated_min_neighbours);
      found[t].points = kept.size();
      found[t].blob =
          put_blob(encode_ply(kept, "arscout dense tile " + names[t]));
    }
    tiles[names[t]] = found[t];
  }
  return tiles;
}

nlohmann::json dense_tiles_json(const DenseTiles& tiles) {
  nlohmann::json array = nlohmann::json::array();
  for (const auto& [name, tile] : tiles)
    array.push_back({{"tile", name},
                     {"blob", tile.blob},
                     {"points", tile.points},
                     {"fused", tile.fused},
                     {"hash", std::to_string(tile.hash)}});
  return array;
}

DenseTiles dense_tiles_from_json(const nlohmann::json& attr) {
  DenseTiles tiles;
  if (!attr.is_array()) return tiles;
  for (const nlohmann::json& entry : attr) {
    DenseTile tile;
    tile.blob = entry.value("blob", "");
    tile.points = entry.value("points", std::size_t{0});
    // Documents from before the outlier pass have no "fused": 0 differs
    // from any tile's count, so the next dense phase stores it again.
    tile.fused = entry.value("fused", std::size_t{0});
    try {
      tile.hash = std::stoull(entry.value("hash", "0"));
    } catch (const std::exception&) {
      tile.hash = 0;  // stored again by the next dense phase
    }
    tiles[entry.value("tile", "")] = tile;
  }
  return tiles;
}

}  // namespace arscout::engine::service

namespace arscout::engine {

std::vector<std::string> dense_cloud_blobs(const db::Document& model) {
  std::vector<std::string> blobs;
  const auto tiles = model.attrs.find("dense_tiles");
  if (tiles != model.attrs.end()) {
    for (const auto& [name, tile] : service::dense_tiles_from_json(*tiles))
      if (!tile.blob.empty()) blobs.push_back(tile.blob);
    return blobs;
  }
  const auto old = model.blobs.find("dense");
  const std::size_t points =
      model.attrs.value("statistics", nlohmann::json::object())
          .value("dense_points", std::size_t{0});
  if (old != model.blobs.end() && points > 0) blobs.push_back(old->second);
  return blobs;
}

std::vector<ColoredPoint> load_dense_cloud(
    db::Store& store, const std::vector<std::string>& blobs) {
  std::vector<ColoredPoint> cloud;
  for (const std::string& blob : blobs) {
    const std::vector<ColoredPoint> tile = decode_ply(store.get_blob(blob));
    cloud.insert(cloud.end(), tile.begin(), tile.end());
  }
  return cloud;
}

}  // namespace arscout::engine
