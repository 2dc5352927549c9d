// The dense cloud's tiles (engine/service/src/dense_tiles.h): a dense phase
// stores only the tiles whose points changed, whatever their order.
#include "dense_tiles.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <set>
#include <string>

#include "arscout/db/document.h"
#include "arscout/engine/service.h"

namespace arscout::engine::service {
namespace {

std::vector<ColoredPoint> random_cloud(std::size_t n, float extent) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-extent, extent);
  std::vector<ColoredPoint> points(n);
  for (ColoredPoint& p : points) {
    p.x = u(rng);
    p.y = u(rng);
    p.z = u(rng) / 4;
    p.r = static_cast<std::uint8_t>(rng());
  }
  return points;
}

// A put_blob that keeps what it was given, by a made-up address.
struct FakeBlobs {
  std::map<std::string, std::string> stored;
  std::string put(const std::string& bytes) {
    const std::string sha = "blob" + std::to_string(stored.size());
    stored[sha] = bytes;
    return sha;
  }
  auto putter() {
    return [this](const std::string& bytes) { return put(bytes); };
  }
};

// The outlier pass runs in each stored tile: a point standing alone is not
// in its PLY, the tile's fused count still holds it, and the same fused
// points stored again keep the blob.
TEST(DenseTiles, IsolatedPointsAreLeftOutOfTheStoredTile) {
  std::vector<ColoredPoint> points;
  for (int i = 0; i < 50; ++i)
    for (int j = 0; j < 50; ++j)
      points.push_back({0.1f * i, 0.1f * j, 0, 1, 1, 1});
  points.push_back({2.5f, 2.5f, 3, 200, 0, 0});  // 3 m above the patch
  FakeBlobs blobs;
  const DenseTiles tiles =
      store_dense_tiles(points, 10, {}, blobs.putter(), 0.25, 2);
  ASSERT_EQ(tiles.size(), 1u);
  const DenseTile& tile = tiles.begin()->second;
  EXPECT_EQ(tile.fused, points.size());
  EXPECT_EQ(tile.points, points.size() - 1);
  const auto content = decode_ply(blobs.stored.at(tile.blob));
  ASSERT_EQ(content.size(), tile.points);
  for (const ColoredPoint& p : content) EXPECT_EQ(p.z, 0);
  const DenseTiles again =
      store_dense_tiles(points, 10, tiles, blobs.putter(), 0.25, 2);
  EXPECT_EQ(again.begin()->second.blob, tile.blob);
  EXPECT_EQ(again.begin()->second.points, tile.points);
  EXPECT_EQ(blobs.stored.size(), 1u);
  // Both counts survive the model document.
  const DenseTiles back = dense_tiles_from_json(dense_tiles_json(tiles));
  EXPECT_EQ(back.begin()->second.fused, tile.fused);
  EXPECT_EQ(back.begin()->second.points, tile.points);
}

TEST(DenseTiles, ColumnsOfTheFrameHoldEveryPointOnce) {
  const auto points = random_cloud(20000, 20);  // 40 m across, 10 m tiles
  FakeBlobs blobs;
  const DenseTiles tiles = store_dense_tiles(points, 10, {}, blobs.putter());
  EXPECT_EQ(tiles.size(), 16u);  // 4 x 4 columns
  EXPECT_TRUE(tiles.count("-2_-2") && tiles.count("1_1"));
  std::size_t total = 0;
  for (const auto& [name, tile] : tiles) {
    const auto content = decode_ply(blobs.stored.at(tile.blob));
    EXPECT_EQ(content.size(), tile.points) << name;
    total += content.size();
    for (const ColoredPoint& p : content) {
      const std::string column =
          std::to_string(static_cast<long long>(std::floor(p.x / 10))) + "_" +
          std::to_string(static_cast<long long>(std::floor(p.y / 10)));
      ASSERT_EQ(column, name);
    }
  }
  EXPECT_EQ(total, points.size());
}

TEST(DenseTiles, OnlyChangedTilesAreStoredAgainInAnyOrder) {
  auto points = random_cloud(20000, 20);
  FakeBlobs blobs;
  const DenseTiles first = store_dense_tiles(points, 10, {}, blobs.putter());
  ASSERT_EQ(blobs.stored.size(), 16u);
  // The same points in another order: nothing to store.
  std::reverse(points.begin(), points.end());
  DenseTiles again = store_dense_tiles(points, 10, first, blobs.putter());
  EXPECT_EQ(blobs.stored.size(), 16u);
  for (const auto& [name, tile] : first)
    EXPECT_EQ(again.at(name).blob, tile.blob) << name;
  // One point's colour changes, one point is added in a new column: two
  // tiles are stored, the rest keep their blobs.
  for (ColoredPoint& p : points)
    if (p.x > 0 && p.x < 10 && p.y > 0 && p.y < 10) {
      p.g = static_cast<std::uint8_t>(p.g + 1);
      break;
    }
  ColoredPoint far;
  far.x = 55;
  far.y = -3;
  points.push_back(far);
  const DenseTiles third = store_dense_tiles(points, 10, again, blobs.putter());
  EXPECT_EQ(blobs.stored.size(), 18u);
  EXPECT_NE(third.at("0_0").blob, again.at("0_0").blob);
  EXPECT_EQ(third.at("5_-1").points, 1u);
  EXPECT_EQ(third.at("1_1").blob, again.at("1_1").blob);
}

// A cloud spread far (stray points, a component placed by its fixes alone)
// must not list more tiles than the model document can hold: the edge
// doubles until there are at most kMaxDenseTiles, every point still in
// exactly one tile of the coarser grid, and the same cloud again stores
// nothing new.
TEST(DenseTiles, AFarSpreadCloudGetsCoarserTilesNotMoreOfThem) {
  auto points = random_cloud(20000, 20);        // 16 tiles of 10 m ...
  const auto stray = random_cloud(3000, 5000);  // ... and ~3000 more
  points.insert(points.end(), stray.begin(), stray.end());
  FakeBlobs blobs;
  const DenseTiles tiles = store_dense_tiles(points, 10, {}, blobs.putter());
  ASSERT_LE(tiles.size(), kMaxDenseTiles);
  ASSERT_GT(tiles.size(), kMaxDenseTiles / 4);  // one doubling too few
  std::size_t total = 0;
  for (const auto& [name, tile] : tiles) {
    const auto content = decode_ply(blobs.stored.at(tile.blob));
    ASSERT_EQ(content.size(), tile.points) << name;
    total += content.size();
  }
  EXPECT_EQ(total, points.size());
  // The coarser edge is 10 m times the smallest power of two that gives
  // at most kMaxDenseTiles columns: every point of a tile lies in its
  // column at that edge.
  auto column = [](const ColoredPoint& p, double edge) {
    return std::to_string(static_cast<long long>(std::floor(p.x / edge))) +
           "_" + std::to_string(static_cast<long long>(std::floor(p.y / edge)));
  };
  double edge = 10;
  for (;; edge *= 2) {
    std::set<std::string> columns;
    for (const ColoredPoint& p : points) columns.insert(column(p, edge));
    if (columns.size() <= kMaxDenseTiles) break;
  }
  EXPECT_GT(edge, 10);
  for (const auto& [name, tile] : tiles) {
    for (const ColoredPoint& p : decode_ply(blobs.stored.at(tile.blob)))
      ASSERT_EQ(column(p, edge), name);
  }
  const std::size_t stored = blobs.stored.size();
  const DenseTiles again = store_dense_tiles(points, 10, tiles, blobs.putter());
  EXPECT_EQ(blobs.stored.size(), stored);
  EXPECT_EQ(again.size(), tiles.size());
}

TEST(DenseTiles, TheModelAttributeRoundTripsAndNamesTheBlobs) {
  FakeBlobs blobs;
  const DenseTiles tiles =
      store_dense_tiles(random_cloud(5000, 20), 10, {}, blobs.putter());
  const DenseTiles back = dense_tiles_from_json(dense_tiles_json(tiles));
  ASSERT_EQ(back.size(), tiles.size());
  for (const auto& [name, tile] : tiles) {
    EXPECT_EQ(back.at(name).blob, tile.blob);
    EXPECT_EQ(back.at(name).hash, tile.hash);
    EXPECT_EQ(back.at(name).points, tile.points);
  }
  db::Document model;
  model.attrs = {{"dense_tiles", dense_tiles_json(tiles)},
                 {"statistics", {{"dense_points", 5000}}}};
  const std::vector<std::string> named = dense_cloud_blobs(model);
  EXPECT_EQ(named.size(), tiles.size());
  // A model written before tiles names its one "dense" blob.
  db::Document old;
  old.attrs = {{"statistics", {{"dense_points", 12}}}};
  old.blobs = db::BlobRefs{{"dense", "abc"}};
  EXPECT_EQ(dense_cloud_blobs(old), std::vector<std::string>{"abc"});
  // Before its first dense phase such a model carried an empty PLY.
  old.attrs["statistics"]["dense_points"] = 0;
  EXPECT_TRUE(dense_cloud_blobs(old).empty());
}

}  // namespace
}  // namespace arscout::engine::service
