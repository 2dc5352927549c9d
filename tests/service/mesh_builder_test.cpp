// The mesh phase's tiles (engine/service/src/mesh_builder.h): within a time
// budget the tiles in most need are made first, the rest stay as published
// and later calls catch up to what one unbounded call makes; the surface's
// grid does not move with small drifts of the dense voxel.
#include "mesh_builder.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <map>
#include <set>
#include <string>
#include <tuple>

#include "dense_tiles.h"

namespace arscout::engine::service {
namespace {

constexpr double kVoxel = 0.05;

// Ground (z = 0) sampled every voxel over x in [0, x_max), y in [0, 1.5),
// normals up, seen by three depth maps; a wall (x = 4.2) over the third
// column of tiles makes that column the largest.
std::vector<ColoredPoint> ground_and_wall(double x_max, std::uint8_t shade) {
  std::vector<ColoredPoint> points;
  auto add = [&](double x, double y, double z, float nx, float nz) {
    ColoredPoint p;
    p.x = static_cast<float>(x);
    p.y = static_cast<float>(y);
    p.z = static_cast<float>(z);
    p.r = p.g = p.b = shade;
    p.nx = nx;
    p.nz = nz;
    p.support = 3;
    points.push_back(p);
  };
  for (double x = 0.01; x < x_max; x += kVoxel)
    for (double y = 0.01; y < 1.5; y += kVoxel) add(x, y, 0, 0, 1);
  for (double y = 0.01; y < 1.5; y += kVoxel)
    for (double z = 0.06; z < 1.0; z += kVoxel) add(4.2, y, z, -1, 0);
  return points;
}

struct Blobs {
  std::map<std::string, std::string> stored;
  std::function<std::string(const std::string&)> putter() {
    return [this](const std::string& bytes) {
      const std::string name =
          "b" + std::to_string(std::hash<std::string>{}(bytes));
      stored[name] = bytes;
      return name;
    };
  }
};

MeshBuildOptions small_tiles(double budget) {
  MeshBuildOptions options;
  options.tile_cells = 16;  // 1.6 m columns at the 0.1 m grid step
  options.budget_seconds = budget;
  return options;
}

void expect_same_tiles(const std::vector<MeshTileEntry>& a,
                       const std::vector<MeshTileEntry>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].tile, b[i].tile);
    EXPECT_EQ(a[i].hash, b[i].hash) << a[i].tile;
    EXPECT_EQ(a[i].cell, b[i].cell) << a[i].tile;
    ASSERT_EQ(a[i].levels.size(), b[i].levels.size()) << a[i].tile;
    for (std::size_t l = 0; l < a[i].levels.size(); ++l)
      EXPECT_EQ(a[i].levels[l].blob, b[i].levels[l].blob) << a[i].tile;
  }
}

TEST(MeshBuilder, ABudgetMakesTheNeediestTilesFirstAndLaterCallsCatchUp) {
  const std::vector<ColoredPoint> cloud = ground_and_wall(4.8, 120);
  Blobs blobs;
  const MeshBuild whole =
      update_mesh_tiles(cloud, kVoxel, {}, {}, blobs.putter(), small_tiles(0));
  ASSERT_GE(whole.tiles.size(), 3u);
  EXPECT_EQ(whole.remade, whole.tiles.size());
  EXPECT_EQ(whole.left, 0u);
  for (const MeshTileEntry& tile : whole.tiles) {
    EXPECT_NEAR(tile.cell, 2 * kVoxel, 1e-12);
    EXPECT_FALSE(tile.levels.empty()) << tile.tile;
  }
  // A budget too small for any second tile: one tile a call, the wall's
  // column (the most points) first.
  MeshBuild step = update_mesh_tiles(cloud, kVoxel, {}, {}, blobs.putter(),
                                     small_tiles(1e-9));
  EXPECT_EQ(step.remade, 1u);
  EXPECT_EQ(step.left, whole.tiles.size() - 1);
  ASSERT_EQ(step.tiles.size(), 1u);
  EXPECT_EQ(step.tiles[0].tile, "2_0");
  std::size_t calls = 1;
  while (step.left > 0 && calls < 20) {
    step = update_mesh_tiles(cloud, kVoxel, step.tiles, {}, blobs.putter(),
                             small_tiles(1e-9));
    EXPECT_EQ(step.remade, 1u);
    ++calls;
  }
  EXPECT_EQ(calls, whole.tiles.size());
  expect_same_tiles(step.tiles, whole.tiles);
  // Nothing changed: nothing made.
  const MeshBuild again = update_mesh_tiles(cloud, kVoxel, whole.tiles, {},
                                            blobs.putter(), small_tiles(1e-9));
  EXPECT_EQ(again.remade, 0u);
  EXPECT_EQ(again.left, 0u);
  expect_same_tiles(again.tiles, whole.tiles);
}

TEST(MeshBuilder, ChangedTilesAreRemadeAndStaleOnesStayPublished) {
  Blobs blobs;
  const MeshBuild before =
      update_mesh_tiles(ground_and_wall(4.8, 120), kVoxel, {}, {},
                        blobs.putter(), small_tiles(0));
  // The ground grows by a column of tiles: the new tile comes first, and
  // with one tile a call the changed old ones keep their surface.
  const std::vector<ColoredPoint> grown = ground_and_wall(6.4, 120);
  const MeshBuild step = update_mesh_tiles(grown, kVoxel, before.tiles, {},
                                           blobs.putter(), small_tiles(1e-9));
  EXPECT_EQ(step.remade, 1u);
  ASSERT_EQ(step.tiles.size(), before.tiles.size() + 1);
  const MeshTileEntry& added = step.tiles.back();
  EXPECT_EQ(added.tile, "3_0");
  EXPECT_FALSE(added.levels.empty());
  // The old column beside it (its margin reads the new points) is stale:
  // published as before, counted as left.
  EXPECT_GE(step.left, 1u);
  for (std::size_t i = 0; i < before.tiles.size(); ++i)
    EXPECT_EQ(step.tiles[i].levels.front().blob,
              before.tiles[i].levels.front().blob);
  // Unbounded, the rest catches up to what a fresh build makes.
  const MeshBuild caught = update_mesh_tiles(grown, kVoxel, step.tiles, {},
                                             blobs.putter(), small_tiles(0));
  EXPECT_EQ(caught.left, 0u);
  expect_same_tiles(
      caught.tiles,
      update_mesh_tiles(grown, kVoxel, {}, {}, blobs.putter(), small_tiles(0))
          .tiles);
}

TEST(MeshBuilder, TheGridStaysWhileTheVoxelDriftsLittle) {
  const std::vector<ColoredPoint> cloud = ground_and_wall(4.8, 120);
  Blobs blobs;
  const MeshBuild first =
      update_mesh_tiles(cloud, kVoxel, {}, {}, blobs.putter(), small_tiles(0));
  // 10 % coarser voxel: the same grid step, nothing made again.
  const MeshBuild drift = update_mesh_tiles(cloud, 1.1 * kVoxel, first.tiles,
                                            {}, blobs.putter(), small_tiles(0));
  for (const MeshTileEntry& tile : drift.tiles)
    EXPECT_NEAR(tile.cell, 2 * kVoxel, 1e-12);
  // 50 % coarser: a new grid, every tile made on it, none of the old kept.
  const MeshBuild moved = update_mesh_tiles(cloud, 1.5 * kVoxel, first.tiles,
                                            {}, blobs.putter(), small_tiles(0));
  EXPECT_EQ(moved.remade, moved.tiles.size());
  for (const MeshTileEntry& tile : moved.tiles)
    EXPECT_NEAR(tile.cell, 3 * kVoxel, 1e-12);
}

// The positions of a mesh's vertices, as a set (texture patches repeat
// some).
using Vertices = std::set<std::tuple<float, float, float>>;
Vertices vertices_of(const TexturedMesh& mesh) {
  Vertices out;
  for (const Eigen::Vector3f& p : mesh.positions)
    out.insert({p.x(), p.y(), p.z()});
  return out;
}

TEST(MeshBuilder, TheTilesTogetherAreTheSurfaceMadeAsOne) {
  // The ground, and a wall slanting across the border between two columns
  // (x = 3.2 m, 1.6 m columns) where it ends.
  std::vector<ColoredPoint> cloud = ground_and_wall(4.0, 120);
  std::erase_if(cloud, [](const ColoredPoint& p) { return p.z > 0; });
  for (double s = 0; s < 1.2; s += kVoxel / 2)
    for (double z = 0.06; z < 1.0; z += kVoxel) {
      ColoredPoint p;
      p.x = static_cast<float>(2.6 + s);
      p.y = static_cast<float>(0.2 + 0.9 * s);
      p.z = static_cast<float>(z);
      p.nx = -0.6f;  // (1, 0.9) turned a quarter, unit
      p.ny = 0.67f;
      p.r = p.g = p.b = 90;
      p.support = 3;
      cloud.push_back(p);
    }
  Blobs blobs;
  const MeshBuild tiled =
      update_mesh_tiles(cloud, kVoxel, {}, {}, blobs.putter(), small_tiles(0));
  ASSERT_EQ(tiled.tiles.size(), 3u);
  Vertices together;
  for (const MeshTileEntry& tile : tiled.tiles) {
    ASSERT_FALSE(tile.levels.empty()) << tile.tile;
    const Vertices mine =
        vertices_of(decode_glb(blobs.stored.at(tile.levels.front().blob)));
    together.insert(mine.begin(), mine.end());
  }
  // One column over the whole cloud, from the same grid and points.
  SurfaceOptions options;
  options.cell = 2 * kVoxel;
  const TexturedMesh one = mesh_surface(
      without_isolated_points(cloud, kIsolatedRadiusVoxels * kVoxel,
                              kIsolatedMinNeighbours),
      {-10, -10}, {10, 10}, kVoxel, options);
  // Over the columns that hold points: the one surface also spills a cell
  // past the points into columns that hold none, which make no tile.
  Vertices whole;
  for (const auto& v : vertices_of(one))
    if (std::get<0>(v) >= 0 && std::get<0>(v) <= 4.8f && std::get<1>(v) >= 0 &&
        std::get<1>(v) <= 1.6f)
      whole.insert(v);
  EXPECT_GT(whole.size(), 1000u);
  // Bit for bit: each tile's border vertices are the whole surface's, so
  // neighbours meet edge to edge.
  EXPECT_EQ(together.size(), whole.size());
  std::size_t missing = 0;
  for (const auto& v : whole) missing += !together.count(v);
  EXPECT_EQ(missing, 0u);
}

// A cloud that changes as a fused one does between calls: a block's stamp
// moves when its points change (DenseReconstruction::cloud_blocks).
class FollowedCloud : public MeshCloud {
 public:
  // The cloud becomes `points`; returns the stamp of the changes so far.
  std::uint64_t set(std::vector<ColoredPoint> points) {
    ++stamp_;
    std::map<Key, CloudBlock> now;
    for (const ColoredPoint& p : points) {
      const auto [it, added] = now.try_emplace(key_of(p));
      CloudBlock& block = it->second;
      if (added) {
        block.min_x = block.max_x = p.x;
        block.min_y = block.max_y = p.y;
      }
      block.changed += dense_point_hash(p);  // the hash, for now
      ++block.points;
      block.min_x = std::min(block.min_x, p.x);
      block.max_x = std::max(block.max_x, p.x);
      block.min_y = std::min(block.min_y, p.y);
      block.max_y = std::max(block.max_y, p.y);
    }
    for (auto& [key, block] : now) {
      const auto was = blocks_.find(key);
      const std::uint64_t hash = block.changed;
      block.changed = was != blocks_.end() && was->second.hash == hash
                          ? was->second.block.changed
                          : stamp_;
      blocks_[key] = {hash, block};
    }
    for (auto& [key, block] : blocks_)  // emptied: listed with no point
      if (!now.count(key) && block.block.points > 0) {
        block.block.points = 0;
        block.block.changed = stamp_;
      }
    points_ = std::move(points);
    return stamp_;
  }
  double block_edge() const override { return kEdge; }
  std::vector<CloudBlock> blocks() const override {
    std::vector<CloudBlock> out;
    for (const auto& [key, block] : blocks_) {
      out.push_back(block.block);
      out.back().ix = key.first;
      out.back().iy = key.second;
    }
    return out;
  }
  std::vector<ColoredPoint> points_in(
      const Eigen::Vector2d& lo, const Eigen::Vector2d& hi) const override {
    std::vector<ColoredPoint> in;
    for (const ColoredPoint& p : points_)
      if (p.x >= lo.x() && p.x < hi.x() && p.y >= lo.y() && p.y < hi.y())
        in.push_back(p);
    return in;
  }

 private:
  using Key = std::pair<long long, long long>;
  static constexpr double kEdge = 16 * kVoxel;
  struct Block {
    std::uint64_t hash = 0;  // of its points
    CloudBlock block;
  };
  static Key key_of(const ColoredPoint& p) {
    return {static_cast<long long>(std::floor(p.x / kEdge)),
            static_cast<long long>(std::floor(p.y / kEdge))};
  }
  std::map<Key, Block> blocks_;
  std::vector<ColoredPoint> points_;
  std::uint64_t stamp_ = 0;
};

TEST(MeshBuilder, ACursorReadsOnlyTheColumnsNearTheChanges) {
  Blobs blobs;
  FollowedCloud cloud;
  std::vector<ColoredPoint> points = ground_and_wall(4.8, 120);
  std::uint64_t now = cloud.set(points);
  MeshBuild build = update_mesh_tiles(cloud, now, kVoxel, {}, {}, {},
                                      blobs.putter(), small_tiles(0));
  ASSERT_EQ(build.tiles.size(), 3u);
  EXPECT_EQ(build.looked_at, 3u);  // no cursor: every column
  // Each later cloud: the columns read are those its changes reach, and
  // the tiles are a fresh build's, bit for bit.
  const auto follow = [&](std::vector<ColoredPoint> next, std::size_t read) {
    points = std::move(next);
    now = cloud.set(points);
    build = update_mesh_tiles(cloud, now, kVoxel, build.tiles, build.cursor, {},
                              blobs.putter(), small_tiles(0));
    EXPECT_EQ(build.looked_at, read);
    EXPECT_EQ(build.left, 0u);
    expect_same_tiles(build.tiles,
                      update_mesh_tiles(points, kVoxel, {}, {}, blobs.putter(),
                                        small_tiles(0))
                          .tiles);
  };
  // Recoloured near x = 0: the first column alone.
  std::vector<ColoredPoint> recoloured = points;
  for (ColoredPoint& p : recoloured)
    if (p.x < 0.4) p.r = 200;
  follow(recoloured, 1);
  // Nothing changed: nothing read.
  follow(points, 0);
  // The last column's points gone: its tile is dropped, and its neighbour,
  // whose margin read them, is read again.
  std::vector<ColoredPoint> cut = points;
  std::erase_if(cut, [](const ColoredPoint& p) { return p.x >= 3.2; });
  follow(cut, 1);
  EXPECT_EQ(build.tiles.size(), 2u);
  // The tiles a budget left are made by the next call from what this one
  // read: unchanged since, they are not read again before.
  std::vector<ColoredPoint> grown = ground_and_wall(6.4, 90);
  points = grown;
  now = cloud.set(points);
  build = update_mesh_tiles(cloud, now, kVoxel, build.tiles, build.cursor, {},
                            blobs.putter(), small_tiles(1e-9));
  EXPECT_EQ(build.remade, 1u);
  EXPECT_EQ(build.cursor.left.size(), build.left);
  ASSERT_GT(build.left, 0u);
  const std::size_t left = build.left;
  follow(grown, 0);
  EXPECT_EQ(build.remade, left);
}

}  // namespace
}  // namespace arscout::engine::service
