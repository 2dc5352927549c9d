// The 3D Tiles export on a synthetic cloud with exact answers: the tileset
// and every glb read back here from their bytes (not with the writers'
// code), every point placed through the root transform within 0.01 m of
// the ECEF PLY's, the octree's boxes nested and its errors shrinking, and
// the zip read by Python's zipfile.
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "arscout/viewer/exports.h"
#include "bytes_at.h"
#include "point_tileset.h"
#include "test_stores.h"
#include "tool_process.h"
#include "zip_writer.h"

namespace arscout::viewer {
namespace {

using Json = nlohmann::json;
namespace fs = std::filesystem;

const engine::Geodetic kLausanne{46.5191, 6.5668, 390.0};
constexpr double kStep = 0.5;  // grid spacing of the synthetic cloud
constexpr int kNx = 90, kNy = 60, kNz = 12;

int grid_index(double x, double y, double z) {
  const int i = static_cast<int>(std::lround(x / kStep));
  const int j = static_cast<int>(std::lround(y / kStep));
  const int k = static_cast<int>(std::lround(z / kStep));
  return (k * kNy + j) * kNx + i;
}

// A block of points on a 0.5 m grid: 64,800 of them, colours from place.
std::vector<engine::ColoredPoint> grid_cloud() {
  std::vector<engine::ColoredPoint> cloud;
  for (int k = 0; k < kNz; ++k)
    for (int j = 0; j < kNy; ++j)
      for (int i = 0; i < kNx; ++i)
        cloud.push_back(
            {static_cast<float>(i * kStep), static_cast<float>(j * kStep),
             static_cast<float>(k * kStep), static_cast<std::uint8_t>(i),
             static_cast<std::uint8_t>(j), static_cast<std::uint8_t>(k)});
  return cloud;
}

using testing_bytes::read_at;

struct TilePoints {
  std::vector<std::array<double, 3>> enu;  // back in the tile frame
  std::vector<std::array<std::uint8_t, 3>> rgb;
};

// A glb's JSON chunk and its points, through its accessors.
TilePoints read_glb(const std::string& glb) {
  TilePoints out;
  EXPECT_EQ(read_at<std::uint32_t>(glb, 0), 0x46546c67u);
  EXPECT_EQ(read_at<std::uint32_t>(glb, 4), 2u);
  EXPECT_EQ(read_at<std::uint32_t>(glb, 8), glb.size());
  const auto json_size = read_at<std::uint32_t>(glb, 12);
  const Json gltf = Json::parse(glb.substr(20, json_size));
  const size_t bin = 20 + json_size + 8;
  const Json& prim = gltf["meshes"][0]["primitives"][0];
  EXPECT_EQ(prim["mode"], 0);
  const Json& pos =
      gltf["accessors"][prim["attributes"]["POSITION"].get<int>()];
  const Json& col = gltf["accessors"][prim["attributes"]["COLOR_0"].get<int>()];
  const size_t pos_at =
      bin + gltf["bufferViews"][pos["bufferView"].get<int>()]["byteOffset"]
                .get<size_t>();
  const size_t col_at =
      bin + gltf["bufferViews"][col["bufferView"].get<int>()]["byteOffset"]
                .get<size_t>();
  const Json& t = gltf["nodes"][0]["translation"];
  for (size_t i = 0; i < pos["count"].get<size_t>(); ++i) {
    const double x = read_at<float>(glb, pos_at + 12 * i) + t[0].get<double>();
    const double y =
        read_at<float>(glb, pos_at + 12 * i + 4) + t[1].get<double>();
    const double z =
        read_at<float>(glb, pos_at + 12 * i + 8) + t[2].get<double>();
    out.enu.push_back({x, -z, y});  // glTF y-up to the tile's z-up
    out.rgb.push_back({static_cast<std::uint8_t>(glb[col_at + 4 * i]),
                       static_cast<std::uint8_t>(glb[col_at + 4 * i + 1]),
                       static_cast<std::uint8_t>(glb[col_at + 4 * i + 2])});
  }
  return out;
}

bool box_inside(const Json& inner, const Json& outer) {
  for (int a = 0; a < 3; ++a) {
    const double h_in = inner[3 + 4 * a].get<double>();
    const double h_out = outer[3 + 4 * a].get<double>();
    if (inner[a].get<double>() - h_in < outer[a].get<double>() - h_out - 1e-6 ||
        inner[a].get<double>() + h_in > outer[a].get<double>() + h_out + 1e-6)
      return false;
  }
  return true;
}

struct Walk {
  std::map<std::string, std::string> files;
  int tiles = 0, leaves = 0;
  std::vector<std::array<double, 3>> enu;
  std::vector<std::array<std::uint8_t, 3>> rgb;
  void tile(const Json& t, const Json* parent) {
    ++tiles;
    EXPECT_EQ(t["refine"], "ADD");
    if (parent) {
      EXPECT_TRUE(box_inside(t["boundingVolume"]["box"],
                             (*parent)["boundingVolume"]["box"]));
      EXPECT_LT(t["geometricError"].get<double>(),
                (*parent)["geometricError"].get<double>());
    }
    const TilePoints points = read_glb(files.at(t["content"]["uri"]));
    enu.insert(enu.end(), points.enu.begin(), points.enu.end());
    rgb.insert(rgb.end(), points.rgb.begin(), points.rgb.end());
    if (!t.contains("children")) {
      ++leaves;
      EXPECT_EQ(t["geometricError"], 0.0);
      return;
    }
    for (const Json& child : t["children"]) tile(child, &t);
  }
};

TEST(PointTileset, EveryPointLandsOnTheEcefPlyWithinACentimetre) {
  const auto cloud = grid_cloud();
  PointTilesetOptions options;
  options.max_tile_points = 4000;
  Walk walk;
  for (auto& f : build_point_tileset(cloud, kLausanne, options))
    walk.files[f.path] = std::move(f.bytes);
  const Json tileset = Json::parse(walk.files.at("tileset.json"));
  EXPECT_EQ(tileset["asset"]["version"], "1.1");
  const Json& root = tileset["root"];
  ASSERT_EQ(root["transform"].size(), 16u);
  EXPECT_GE(tileset["geometricError"].get<double>(),
            root["geometricError"].get<double>());
  walk.tile(root, nullptr);
  EXPECT_GT(walk.leaves, 8);
  EXPECT_EQ(walk.files.size(), static_cast<size_t>(walk.tiles) + 1);
  ASSERT_EQ(walk.enu.size(), cloud.size());

  const std::string ply = encode_ecef_ply(cloud, kLausanne, "truth");
  const size_t body = ply.find("end_header\n") + 11;
  std::vector<int> seen(cloud.size(), 0);
  double worst = 0;
  const Json& m = root["transform"];  // column-major
  for (size_t n = 0; n < walk.enu.size(); ++n) {
    const auto& p = walk.enu[n];
    const int index = grid_index(p[0], p[1], p[2]);
    ASSERT_GE(index, 0);
    ASSERT_LT(index, static_cast<int>(cloud.size()));
    ++seen[index];
    for (int r = 0; r < 3; ++r) {
      const double ecef =
          m[r].get<double>() * p[0] + m[4 + r].get<double>() * p[1] +
          m[8 + r].get<double>() * p[2] + m[12 + r].get<double>();
      const double truth = read_at<double>(ply, body + 27 * index + 8 * r);
      worst = std::max(worst, std::abs(ecef - truth));
    }
    EXPECT_EQ(walk.rgb[n][0], cloud[index].r);
    EXPECT_EQ(walk.rgb[n][2], cloud[index].b);
  }
  for (size_t i = 0; i < seen.size(); ++i) ASSERT_EQ(seen[i], 1) << i;
  std::cout << walk.tiles << " tiles (" << walk.leaves
            << " leaves); worst distance to the ECEF PLY " << worst * 1000
            << " mm" << std::endl;
  EXPECT_LT(worst, 0.01);
}

TEST(ZipWriter, PythonsZipfileReadsItBack) {
  if (testing::command_output("python3 -c 'import zipfile'; echo ok") != "ok\n")
    GTEST_SKIP() << "no python3 here";
  ZipWriter zip;
  const std::string big(100000, 'x');
  zip.add("site/tileset.json", "{}", 1764115200);
  zip.add("site/tiles/r.glb", big, 1764115200);
  const fs::path dir = testing::make_temp_dir("zip");
  std::ofstream(dir / "a.zip", std::ios::binary) << zip.finish();
  const std::string listed = testing::command_output(
      "python3 -c \"import zipfile,sys; z=zipfile.ZipFile(sys.argv[1]); "
      "assert z.testzip() is None; "
      "print([(i.filename, i.file_size, i.date_time) for i in z.infolist()])\" "
      "'" +
      (dir / "a.zip").string() + "'");
  EXPECT_EQ(listed,
            "[('site/tileset.json', 2, (2025, 11, 26, 0, 0, 0)), "
            "('site/tiles/r.glb', 100000, (2025, 11, 26, 0, 0, 0))]\n");
  EXPECT_THROW(zip.add("", "x", 0), std::invalid_argument);
}

}  // namespace
}  // namespace arscout::viewer
