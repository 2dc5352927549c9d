// The mesh phase's tiles (engine/service/src/mesh_builder.h): within a time
// budget the tiles in most need are made first, the rest stay as published
// and later calls catch up to what one unbounded call makes; the surface's
// grid does not move with small drifts of the dense voxel.
#include "mesh_builder.h"

#include <gtest/gtest.h>

#include <functional>
#include <map>
#include <string>

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

}  // namespace
}  // namespace arscout::engine::service
