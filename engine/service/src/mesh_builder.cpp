#include "mesh_builder.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <set>

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

// A share of a column's edge: slack for bounds that for_tiles_of's division
// and a float point may place either side of.
constexpr double kHair = 1e-4;

// Whether `p` is among the points the surface of column `key` reads, and
// whether in the column itself (for_tiles_of's test).
bool reads(const ColoredPoint& p, const MeshTileKey& key, double edge,
           double margin, bool* own) {
  bool found = false;
  for_tiles_of(p, edge, margin, [&](const MeshTileKey& k, bool in_column) {
    if (k != key) return;
    found = true;
    *own = in_column;
  });
  return found;
}

// A column's x-y bounds, grown by `reach` on every side.
std::pair<Eigen::Vector2d, Eigen::Vector2d> column_box(const MeshTileKey& key,
                                                       double edge,
                                                       double reach) {
  // Each bound from its own index: a neighbour's lower bound is then this
  // column's upper one to the bit.
  const Eigen::Vector2d lo(static_cast<double>(key.first) * edge,
                           static_cast<double>(key.second) * edge);
  const Eigen::Vector2d hi(static_cast<double>(key.first + 1) * edge,
                           static_cast<double>(key.second + 1) * edge);
  const Eigen::Vector2d grow(reach, reach);
  return {lo - grow, hi + grow};
}

// The points a column's surface reads (its own and its margin's), in the
// cloud's order, and how many are its own (when `own_count` is given).
std::vector<ColoredPoint> inputs_of(const MeshCloud& cloud,
                                    const MeshTileKey& key, double edge,
                                    double margin, std::size_t* own_count) {
  // A hair more: points_in tests the points, for_tiles_of divides them.
  const auto [lo, hi] = column_box(key, edge, margin + kHair * edge);
  std::vector<ColoredPoint> points = cloud.points_in(lo, hi);
  std::size_t own_points = 0;
  std::erase_if(points, [&](const ColoredPoint& p) {
    bool own = false;
    if (!reads(p, key, edge, margin, &own)) return true;
    own_points += own;
    return false;
  });
  if (own_count) *own_count = own_points;
  return points;
}

// The columns of `edge` that the points of the blocks `take` accepts lie
// in, or reach within `reach` (for_tiles_of's floor of x / edge).
template <typename Take>
std::set<MeshTileKey> columns_of_blocks(const std::vector<CloudBlock>& blocks,
                                        double edge, double reach,
                                        Take&& take) {
  std::set<MeshTileKey> columns;
  const auto column = [edge](double v) {
    return static_cast<long long>(std::floor(v / edge));
  };
  for (const CloudBlock& block : blocks) {
    // Bounds past every finite point (a stray sample at infinity): its
    // points have no column (for_tiles_of).
    if (!take(block) || !std::isfinite(block.min_x) ||
        !std::isfinite(block.max_x) || !std::isfinite(block.min_y) ||
        !std::isfinite(block.max_y) || block.min_x > block.max_x)
      continue;
    for (long long ix = column(block.min_x - reach);
         ix <= column(block.max_x + reach); ++ix)
      for (long long iy = column(block.min_y - reach);
           iy <= column(block.max_y + reach); ++iy)
        columns.insert({ix, iy});
  }
  return columns;
}

// A cloud given whole, bucketed by blocks, every block stamped 1.
class WholeCloud : public MeshCloud {
 public:
  WholeCloud(const std::vector<ColoredPoint>& points, double block_edge)
      : points_(points), edge_(block_edge) {
    // A point past for_tiles_of's range has no column: no block either.
    for (std::size_t i = 0; i < points.size(); ++i)
      if (std::abs(points[i].x / edge_) < 1e9 &&
          std::abs(points[i].y / edge_) < 1e9)
        buckets_[block_of(points[i])].push_back(i);
  }
  double block_edge() const override { return edge_; }
  std::vector<CloudBlock> blocks() const override {
    std::vector<CloudBlock> blocks;
    for (const auto& [key, members] : buckets_) {
      CloudBlock block{key.first, key.second, 1, members.size()};
      block.min_x = block.max_x = points_[members.front()].x;
      block.min_y = block.max_y = points_[members.front()].y;
      for (const std::size_t i : members) {
        block.min_x = std::min(block.min_x, points_[i].x);
        block.max_x = std::max(block.max_x, points_[i].x);
        block.min_y = std::min(block.min_y, points_[i].y);
        block.max_y = std::max(block.max_y, points_[i].y);
      }
      blocks.push_back(block);
    }
    return blocks;
  }
  std::vector<ColoredPoint> points_in(
      const Eigen::Vector2d& lo, const Eigen::Vector2d& hi) const override {
    std::vector<std::size_t> at;
    for (const auto& [key, members] : buckets_)
      if (overlaps(key, lo, hi))
        at.insert(at.end(), members.begin(), members.end());
    std::sort(at.begin(), at.end());
    std::vector<ColoredPoint> points;
    for (const std::size_t i : at) {
      const ColoredPoint& p = points_[i];
      if (p.x >= lo.x() && p.x < hi.x() && p.y >= lo.y() && p.y < hi.y())
        points.push_back(p);
    }
    return points;
  }

 private:
  MeshTileKey block_of(const ColoredPoint& p) const {
    return {static_cast<long long>(std::floor(p.x / edge_)),
            static_cast<long long>(std::floor(p.y / edge_))};
  }
  bool overlaps(const MeshTileKey& key, const Eigen::Vector2d& lo,
                const Eigen::Vector2d& hi) const {
    const double x = static_cast<double>(key.first) * edge_;
    const double y = static_cast<double>(key.second) * edge_;
    return x + edge_ >= lo.x() && x <= hi.x() && y + edge_ >= lo.y() &&
           y <= hi.y();
  }
  const std::vector<ColoredPoint>& points_;
  double edge_;
  std::map<MeshTileKey, std::vector<std::size_t>> buckets_;
};

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
  const auto [lo, hi] = column_box(key, edge, 0);
  SurfaceOptions surface_options = options.surface;
  surface_options.cell = cell;
  // The pass the published tiles had, over the tile and its margin: a
  // point the surface reads has all its neighbours in the margin, so two
  // tiles judge it alike.
  const TexturedMesh surface = mesh_surface(
      without_isolated_points(points, kIsolatedRadiusVoxels * voxel,
                              kIsolatedMinNeighbours),
      lo, hi, voxel, surface_options);
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

// The queue's tiles made in order while the budget allows (after the
// first), each from its column's points read again.
std::map<MeshTileKey, MeshTileEntry> make_queued(
    const std::vector<Need>& queue, const MeshCloud& cloud,
    const TileGeometry& at,
    const std::vector<DenseReconstruction::KeyView>& views,
    const std::function<std::string(const std::string&)>& put_blob,
    const MeshBuildOptions& options,
    std::chrono::steady_clock::time_point start) {
  std::map<MeshTileKey, MeshTileEntry> made;
  std::size_t points_made = 0;
  const auto making = std::chrono::steady_clock::now();
  for (const Need& need : queue) {
    // The next tile's cost estimated from this call's tiles, per point.
    const double estimate =
        seconds_since(making) /
        static_cast<double>(std::max<std::size_t>(points_made, 1)) *
        static_cast<double>(need.points);
    if (options.budget_seconds > 0 && !made.empty() &&
        seconds_since(start) + estimate > options.budget_seconds)
      break;
    made[need.key] = make_tile(
        need.key, inputs_of(cloud, need.key, at.edge, at.margin, nullptr),
        at.edge, at.voxel, at.cell, views, put_blob, options);
    points_made += need.points;
  }
  return made;
}

// The columns a call reads again: near a block changed since the cursor
// (every column with a block when the cursor is for another grid, or
// none), of those holding a block at all.
std::set<MeshTileKey> columns_to_look_at(const std::vector<CloudBlock>& blocks,
                                         const TileGeometry& at,
                                         const MeshCursor& since,
                                         const std::set<MeshTileKey>& held) {
  if (since.seen == 0 || since.cell != at.cell) return held;
  std::set<MeshTileKey> look = columns_of_blocks(
      blocks, at.edge, at.margin + kHair * at.edge,
      [&](const CloudBlock& block) { return block.changed > since.seen; });
  std::erase_if(look, [&](const MeshTileKey& k) { return !held.count(k); });
  return look;
}

// A column's inputs as read: their hash and count.
struct Column {
  std::uint64_t hash = 0;
  std::size_t points = 0;
};

std::map<MeshTileKey, Column> read_columns(const MeshCloud& cloud,
                                           const std::set<MeshTileKey>& keys,
                                           const TileGeometry& at) {
  std::map<MeshTileKey, Column> columns;
  for (const MeshTileKey& key : keys) {
    std::size_t own = 0;
    const std::vector<ColoredPoint> inputs =
        inputs_of(cloud, key, at.edge, at.margin, &own);
    // A column with margin points alone has no cell of its own to mesh.
    if (own == 0) continue;
    Column& column = columns[key];
    for (const ColoredPoint& p : inputs) column.hash += dense_point_hash(p);
    column.points = inputs.size();
  }
  return columns;
}

// The changed columns' places in the queue (see Need).
std::vector<Need> queue_of(
    const std::map<MeshTileKey, Column>& columns,
    const std::map<std::string, const MeshTileEntry*>& before) {
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
  return queue;
}

StaleColumn stale(const MeshTileKey& key, const Column& column) {
  return {key.first, key.second, column.hash, column.points};
}

// Each column's tile after a call: made now, kept, or left stale; a
// column never made and left has none. Counts into `build`.
void gather_tiles(const std::set<MeshTileKey>& held,
                  const std::map<MeshTileKey, Column>& looked,
                  const std::map<MeshTileKey, MeshTileEntry>& made,
                  const std::map<std::string, const MeshTileEntry*>& before,
                  const std::set<MeshTileKey>& looked_at, MeshBuild* build) {
  const auto publish = [build](const MeshTileEntry& entry) {
    if (!entry.levels.empty())
      build->triangles += entry.levels.front().triangles;
    build->tiles.push_back(entry);
  };
  for (const MeshTileKey& key : held) {
    const auto was = before.find(name_of(key));
    const auto column = looked.find(key);
    if (column == looked.end()) {
      // Not read again: unchanged since the cursor; gone if read and empty.
      if (!looked_at.count(key) && was != before.end()) publish(*was->second);
    } else if (const auto it = made.find(key); it != made.end()) {
      MeshTileEntry entry = it->second;
      entry.hash = column->second.hash;
      publish(entry);
      ++build->remade;
    } else if (was != before.end()) {
      publish(*was->second);  // unchanged, or stale until a later call
      if (was->second->hash != column->second.hash) {
        ++build->left;
        build->cursor.left.push_back(stale(key, column->second));
      }
    } else {
      ++build->left;  // never made: nothing to publish yet
      ++build->left_new;
      build->cursor.left.push_back(stale(key, column->second));
    }
  }
}

}  // namespace

MeshBuild update_mesh_tiles(
    const MeshCloud& cloud, std::uint64_t now, double voxel,
    const std::vector<MeshTileEntry>& published, const MeshCursor& since,
    const std::vector<DenseReconstruction::KeyView>& views,
    const std::function<std::string(const std::string& bytes)>& put_blob,
    const MeshBuildOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  TileGeometry at;
  at.voxel = voxel;
  at.cell = grid_cell(published, voxel, options);
  at.edge = options.tile_cells * at.cell;
  at.margin = (options.surface.radius_cells + 2) * at.cell +
              kIsolatedRadiusVoxels * voxel;
  std::map<std::string, const MeshTileEntry*> before;
  for (const MeshTileEntry& e : published)
    if (e.cell == at.cell) before[e.tile] = &e;  // another grid's: dropped
  const std::vector<CloudBlock> blocks = cloud.blocks();
  // The columns a block may hold a point of.
  const std::set<MeshTileKey> held = columns_of_blocks(
      blocks, at.edge, 0, [](const CloudBlock& b) { return b.points > 0; });
  const std::set<MeshTileKey> look =
      columns_to_look_at(blocks, at, since, held);
  std::map<MeshTileKey, Column> looked = read_columns(cloud, look, at);
  // The columns left stale and unchanged since: as the cursor read them.
  if (since.cell == at.cell)
    for (const StaleColumn& c : since.left)
      if (held.count({c.ix, c.iy}) && !look.count({c.ix, c.iy}))
        looked[{c.ix, c.iy}] = Column{c.hash, c.points};
  const std::map<MeshTileKey, MeshTileEntry> made = make_queued(
      queue_of(looked, before), cloud, at, views, put_blob, options, start);
  MeshBuild build;
  build.cursor.seen = now;
  build.cursor.cell = at.cell;
  build.looked_at = look.size();
  gather_tiles(held, looked, made, before, look, &build);
  build.seconds = seconds_since(start);
  return build;
}

MeshBuild update_mesh_tiles(
    const std::vector<ColoredPoint>& cloud, double voxel,
    const std::vector<MeshTileEntry>& published,
    const std::vector<DenseReconstruction::KeyView>& views,
    const std::function<std::string(const std::string& bytes)>& put_blob,
    const MeshBuildOptions& options) {
  const WholeCloud whole(cloud, 16 * voxel);
  return update_mesh_tiles(whole, 0, voxel, published, {}, views, put_blob,
                           options);
}

}  // namespace arscout::engine::service
