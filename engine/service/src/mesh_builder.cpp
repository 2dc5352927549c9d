#include "mesh_builder.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>

#include "arscout/util/clock.h"
#include "dense_tiles.h"

namespace arscout::engine::service {
namespace {

using util::seconds_since;

using MeshTileKey = std::pair<long long, long long>;

std::string name_of(const MeshTileKey& key) {
  return dense_tile_name(key.first, key.second);
}

// Calls fn(key, own) for the tile of `p` (own: true) and each neighbour
// within `margin` (false).
template <typename Fn>
void for_tiles_of(const ColoredPoint& p, double edge, double margin, Fn&& fn) {
  const double fx = p.x / edge, fy = p.y / edge;
  if (!std::isfinite(fx) || !std::isfinite(fy) || std::abs(fx) > 1e9 ||
      std::abs(fy) > 1e9)
    return;
  const long long ix = static_cast<long long>(std::floor(fx));
  const long long iy = static_cast<long long>(std::floor(fy));
  const double m = margin / edge;
  const int x_lo = fx - ix < m ? -1 : 0, x_hi = ix + 1 - fx < m ? 1 : 0;
  const int y_lo = fy - iy < m ? -1 : 0, y_hi = iy + 1 - fy < m ? 1 : 0;
  for (int dx = x_lo; dx <= x_hi; ++dx)
    for (int dy = y_lo; dy <= y_hi; ++dy)
      fn(MeshTileKey{ix + dx, iy + dy}, dx == 0 && dy == 0);
}

// The points a column's surface reads: its own and its margin's.
struct Column {
  std::uint64_t hash = 0;  // of them all
  std::size_t points = 0;
  std::size_t own = 0;  // in the column itself
};

// The columns over the cloud's bounds, numbered row by row: a dense array
// instead of a map in the passes over every point.
class ColumnGrid {
 public:
  ColumnGrid(const std::vector<ColoredPoint>& cloud, double edge) {
    for (const ColoredPoint& p : cloud)
      for_tiles_of(p, edge, 0, [&](const MeshTileKey& k, bool) {
        lo_ = {std::min(lo_.first, k.first), std::min(lo_.second, k.second)};
        hi_ = {std::max(hi_.first, k.first), std::max(hi_.second, k.second)};
      });
  }
  std::size_t size() const {
    if (lo_.first > hi_.first) return 0;  // no finite point
    return static_cast<std::size_t>(hi_.first - lo_.first + 1) * height();
  }
  bool inside(const MeshTileKey& k) const {
    return k.first >= lo_.first && k.first <= hi_.first &&
           k.second >= lo_.second && k.second <= hi_.second;
  }
  std::size_t slot(const MeshTileKey& k) const {
    return static_cast<std::size_t>(k.first - lo_.first) * height() +
           static_cast<std::size_t>(k.second - lo_.second);
  }
  MeshTileKey key(std::size_t at) const {
    return {lo_.first + static_cast<long long>(at / height()),
            lo_.second + static_cast<long long>(at % height())};
  }

 private:
  std::size_t height() const {
    return static_cast<std::size_t>(hi_.second - lo_.second + 1);
  }
  MeshTileKey lo_{std::numeric_limits<long long>::max(),
                  std::numeric_limits<long long>::max()};
  MeshTileKey hi_{std::numeric_limits<long long>::min(),
                  std::numeric_limits<long long>::min()};
};

// Per column with a point of its own: the hash, count and own count of
// the points its surface reads. One pass over the cloud.
std::map<MeshTileKey, Column> columns_read(
    const std::vector<ColoredPoint>& cloud, const ColumnGrid& grid, double edge,
    double margin) {
  std::vector<Column> columns(grid.size());
  for (const ColoredPoint& p : cloud)
    for_tiles_of(p, edge, margin, [&](const MeshTileKey& k, bool own) {
      if (!grid.inside(k)) return;  // a margin past every point's column
      Column& column = columns[grid.slot(k)];
      column.hash += dense_point_hash(p);
      ++column.points;
      column.own += own;
    });
  std::map<MeshTileKey, Column> out;
  for (std::size_t c = 0; c < columns.size(); ++c)
    if (columns[c].own > 0) out[grid.key(c)] = columns[c];
  return out;
}

// The points each of `keys`' surfaces reads, as columns_read counted
// them, in the cloud's order. One pass over the cloud.
std::vector<std::vector<ColoredPoint>> inputs_of(
    const std::vector<ColoredPoint>& cloud, const ColumnGrid& grid, double edge,
    double margin, const std::vector<MeshTileKey>& keys) {
  std::vector<int> wanted(grid.size(), -1);
  for (std::size_t i = 0; i < keys.size(); ++i)
    wanted[grid.slot(keys[i])] = static_cast<int>(i);
  std::vector<std::vector<ColoredPoint>> inputs(keys.size());
  for (const ColoredPoint& p : cloud)
    for_tiles_of(p, edge, margin, [&](const MeshTileKey& k, bool) {
      if (!grid.inside(k)) return;
      if (const int i = wanted[grid.slot(k)]; i >= 0) inputs[i].push_back(p);
    });
  return inputs;
}

// The key views that see the tile's box, nearest first, at most `limit`.
std::vector<TextureView> views_of(
    const TexturedMesh& surface,
    const std::vector<DenseReconstruction::KeyView>& views, int limit) {
  Eigen::Vector3f lo = surface.positions.front(), hi = lo;
  for (const Eigen::Vector3f& p : surface.positions) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const Eigen::Vector3d centre = ((lo + hi) / 2).cast<double>();
  std::vector<std::pair<double, std::size_t>> seeing;
  for (std::size_t v = 0; v < views.size(); ++v) {
    const DepthMap& map = views[v].map;
    bool sees = false;
    for (int corner = 0; corner < 8 && !sees; ++corner) {
      const Eigen::Vector3d p((corner & 1 ? hi : lo).x(),
                              (corner & 2 ? hi : lo).y(),
                              (corner & 4 ? hi : lo).z());
      const Eigen::Vector3d c = map.R * p + map.t;
      if (c.z() <= 0) continue;
      const Eigen::Vector3d h = map.K * c;
      sees = h.x() / h.z() >= 0 && h.y() / h.z() >= 0 &&
             h.x() / h.z() < views[v].bgr.cols &&
             h.y() / h.z() < views[v].bgr.rows;
    }
    if (sees)
      seeing.push_back({(map.R.transpose() * -map.t - centre).norm(), v});
  }
  std::sort(seeing.begin(), seeing.end());
  if (static_cast<int>(seeing.size()) > limit) seeing.resize(limit);
  std::vector<DenseReconstruction::KeyView> nearest;
  for (const auto& [distance, v] : seeing) nearest.push_back(views[v]);
  return texture_views(nearest);
}

// One tile made: surface, texture, levels, each level's GLB stored.
MeshTileEntry make_tile(
    const MeshTileKey& key, const std::vector<ColoredPoint>& points,
    double edge, double voxel, double cell,
    const std::vector<DenseReconstruction::KeyView>& views,
    const std::function<std::string(const std::string&)>& put_blob,
    const MeshBuildOptions& options) {
  MeshTileEntry entry;
  entry.tile = name_of(key);
  entry.points = points.size();
  entry.cell = cell;
  const Eigen::Vector2d lo(static_cast<double>(key.first) * edge,
                           static_cast<double>(key.second) * edge);
  SurfaceOptions surface_options = options.surface;
  surface_options.cell = cell;
  // The pass the published tiles had, over the tile and its margin: a
  // point the surface reads has all its neighbours in the margin, so two
  // tiles judge it alike.
  const TexturedMesh surface = mesh_surface(
      without_isolated_points(points, kIsolatedRadiusVoxels * voxel,
                              kIsolatedMinNeighbours),
      lo, lo + Eigen::Vector2d(edge, edge), voxel, surface_options);
  if (surface.empty()) return entry;
  const TexturedMesh textured = texture_mesh(
      surface, views_of(surface, views, options.max_views), options.texture);
  // The levels share the atlas: compressed once, embedded in each GLB.
  const std::string atlas =
      encode_atlas_jpeg(textured.atlas, options.jpeg_quality);
  for (MeshLevel& level : mesh_levels(textured, options.levels)) {
    const std::size_t triangles = level.mesh.triangles();
    GlbMesh glb{std::move(level.mesh), atlas,
                atlas.empty() ? "" : "image/jpeg"};
    glb.mesh.atlas.release();
    entry.levels.push_back(
        {put_blob(encode_glb_meshes({glb})), triangles, level.geometric_error});
  }
  return entry;
}

// The published tiles' grid step while 2 * voxel stays near it, else
// 2 * voxel (or the options' fixed step).
double grid_cell(const std::vector<MeshTileEntry>& published, double voxel,
                 const MeshBuildOptions& options) {
  if (options.surface.cell > 0) return options.surface.cell;
  const double wanted = 2 * voxel;
  for (const MeshTileEntry& tile : published)
    if (tile.cell > 0 && wanted <= 1.25 * tile.cell &&
        tile.cell <= 1.25 * wanted)
      return tile.cell;
  return wanted;
}

// A changed tile's place in the queue: never made first (the larger first),
// then by the share its point count changed since it was made.
struct Need {
  bool never_made = false;
  double change = 0;
  std::size_t points = 0;
  MeshTileKey key;
  bool operator<(const Need& o) const {
    if (never_made != o.never_made) return never_made;
    if (never_made && points != o.points) return points > o.points;
    if (change != o.change) return change > o.change;
    return key < o.key;
  }
};

// Where a call's tiles lie and what they read.
struct TileGeometry {
  double edge = 0;    // of a column
  double margin = 0;  // read around it
  double voxel = 0;   // the dense cloud's
  double cell = 0;    // the surface's grid step
};

// Tiles whose inputs one pass over the cloud gathers.
constexpr std::size_t kTilesPerPass = 32;

// The queue's tiles made in order while the budget allows (after the
// first), their inputs read kTilesPerPass at a time.
std::map<MeshTileKey, MeshTileEntry> make_queued(
    const std::vector<Need>& queue, const std::vector<ColoredPoint>& cloud,
    const ColumnGrid& grid, const TileGeometry& at,
    const std::vector<DenseReconstruction::KeyView>& views,
    const std::function<std::string(const std::string&)>& put_blob,
    const MeshBuildOptions& options,
    std::chrono::steady_clock::time_point start) {
  std::map<MeshTileKey, MeshTileEntry> made;
  std::size_t points_made = 0;
  const auto making = std::chrono::steady_clock::now();
  for (std::size_t first = 0; first < queue.size(); first += kTilesPerPass) {
    const std::size_t last = std::min(queue.size(), first + kTilesPerPass);
    std::vector<MeshTileKey> keys;
    for (std::size_t q = first; q < last; ++q) keys.push_back(queue[q].key);
    std::vector<std::vector<ColoredPoint>> inputs =
        inputs_of(cloud, grid, at.edge, at.margin, keys);
    for (std::size_t q = first; q < last; ++q) {
      // The next tile's cost estimated from this call's tiles, per point.
      const double estimate =
          seconds_since(making) /
          static_cast<double>(std::max<std::size_t>(points_made, 1)) *
          static_cast<double>(queue[q].points);
      if (options.budget_seconds > 0 && !made.empty() &&
          seconds_since(start) + estimate > options.budget_seconds)
        return made;
      made[queue[q].key] =
          make_tile(queue[q].key, inputs[q - first], at.edge, at.voxel, at.cell,
                    views, put_blob, options);
      inputs[q - first].clear();
      inputs[q - first].shrink_to_fit();
      points_made += queue[q].points;
    }
  }
  return made;
}

}  // namespace

MeshBuild update_mesh_tiles(
    const std::vector<ColoredPoint>& cloud, double voxel,
    const std::vector<MeshTileEntry>& published,
    const std::vector<DenseReconstruction::KeyView>& views,
    const std::function<std::string(const std::string& bytes)>& put_blob,
    const MeshBuildOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const double cell = grid_cell(published, voxel, options);
  const double edge = options.tile_cells * cell;
  const double margin =
      (options.surface.radius_cells + 2) * cell + kIsolatedRadiusVoxels * voxel;
  const ColumnGrid grid(cloud, edge);
  // A column with margin points alone has no cell of its own to mesh.
  const std::map<MeshTileKey, Column> columns =
      columns_read(cloud, grid, edge, margin);
  std::map<std::string, const MeshTileEntry*> before;
  for (const MeshTileEntry& e : published)
    if (e.cell == cell) before[e.tile] = &e;  // another grid's: dropped
  std::vector<Need> queue;
  for (const auto& [key, column] : columns) {
    const auto was = before.find(name_of(key));
    if (was != before.end() && was->second->hash == column.hash) continue;
    Need need{was == before.end(), 0, column.points, key};
    if (!need.never_made)
      need.change = std::abs(static_cast<double>(column.points) -
                             static_cast<double>(was->second->points)) /
                    std::max<double>(1, was->second->points);
    queue.push_back(need);
  }
  std::sort(queue.begin(), queue.end());
  const std::map<MeshTileKey, MeshTileEntry> made =
      make_queued(queue, cloud, grid, {edge, margin, voxel, cell}, views,
                  put_blob, options, start);
  MeshBuild build;
  for (const auto& [key, column] : columns) {
    MeshTileEntry entry;
    if (const auto it = made.find(key); it != made.end()) {
      entry = it->second;
      entry.hash = column.hash;
      ++build.remade;
    } else if (const auto was = before.find(name_of(key));
               was != before.end()) {
      entry = *was->second;  // unchanged, or stale until a later call
      build.left += entry.hash != column.hash;
    } else {
      ++build.left;  // never made: nothing to publish yet
      ++build.left_new;
      continue;
    }
    if (!entry.levels.empty())
      build.triangles += entry.levels.front().triangles;
    build.tiles.push_back(std::move(entry));
  }
  build.seconds = seconds_since(start);
  return build;
}

}  // namespace arscout::engine::service
