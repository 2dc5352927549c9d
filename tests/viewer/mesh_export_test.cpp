// The mesh exports (glb, obj, 3dtiles-mesh; docs/mesh.md, "Exports") of a
// synthetic site (synthetic_mesh_site.h), read back here from their bytes:
// the zips by their central directory, the glTF by its JSON and accessors,
// the OBJ line by line; vertices against the meshes that were stored, the
// tileset's chains against their levels, its transform against the ENU
// frame. Third-party readers check the same files in mesh_export_test.sh
// (the Khronos glTF validator, the 3D Tiles schema, 3d-tiles-renderer).
#include <cmath>
#include <cstdint>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "arscout/engine/geo.h"
#include "arscout/util/error.h"
#include "arscout/viewer/exports.h"
#include "bytes_at.h"
#include "synthetic_mesh_site.h"
#include "test_stores.h"

namespace arscout::viewer {
namespace {

using Json = nlohmann::json;
using testing_bytes::read_at;

// A zip's files by name, through its central directory (stored entries:
// what ZipWriter writes).
std::map<std::string, std::string> unzip(const std::string& zip) {
  std::map<std::string, std::string> files;
  std::size_t end = zip.size() - 22;
  while (end > 0 && read_at<std::uint32_t>(zip, end) != 0x06054b50) --end;
  EXPECT_EQ(read_at<std::uint32_t>(zip, end), 0x06054b50u);
  std::size_t at = read_at<std::uint32_t>(zip, end + 16);
  for (int i = 0; i < read_at<std::uint16_t>(zip, end + 10); ++i) {
    EXPECT_EQ(read_at<std::uint32_t>(zip, at), 0x02014b50u);
    EXPECT_EQ(read_at<std::uint16_t>(zip, at + 10), 0);  // stored
    const std::uint32_t size = read_at<std::uint32_t>(zip, at + 24);
    const std::uint16_t name_size = read_at<std::uint16_t>(zip, at + 28);
    const std::size_t local = read_at<std::uint32_t>(zip, at + 42);
    const std::string name = zip.substr(at + 46, name_size);
    const std::size_t data = local + 30 +
                             read_at<std::uint16_t>(zip, local + 26) +
                             read_at<std::uint16_t>(zip, local + 28);
    files[name] = zip.substr(data, size);
    at += 46 + name_size + read_at<std::uint16_t>(zip, at + 30) +
          read_at<std::uint16_t>(zip, at + 32);
  }
  return files;
}

Json gltf_json(const std::string& glb) {
  return Json::parse(glb.substr(20, read_at<std::uint32_t>(glb, 12)));
}

// Primitive `p`'s positions in glTF's frame (the node's translation added).
std::vector<Eigen::Vector3d> gltf_positions(const std::string& glb, int p) {
  const Json gltf = gltf_json(glb);
  const Json& accessor =
      gltf["accessors"]
          [gltf["meshes"][0]["primitives"][p]["attributes"]["POSITION"]
               .get<int>()];
  EXPECT_EQ(accessor["componentType"], 5126);
  const Json& view = gltf["bufferViews"][accessor["bufferView"].get<int>()];
  const std::size_t bin = 20 + read_at<std::uint32_t>(glb, 12) + 8;
  const std::size_t at = bin + view["byteOffset"].get<std::size_t>();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  if (gltf["nodes"][0].contains("translation"))
    for (int a = 0; a < 3; ++a)
      t[a] = gltf["nodes"][0]["translation"][a].get<double>();
  std::vector<Eigen::Vector3d> out;
  for (std::size_t i = 0; i < accessor["count"].get<std::size_t>(); ++i)
    out.push_back(t + Eigen::Vector3d(read_at<float>(glb, at + 12 * i),
                                      read_at<float>(glb, at + 12 * i + 4),
                                      read_at<float>(glb, at + 12 * i + 8)));
  return out;
}

// glTF's y up back to the site frame's z up.
Eigen::Vector3d z_up(const Eigen::Vector3d& p) {
  return {p.x(), -p.z(), p.y()};
}

double farthest(const std::vector<Eigen::Vector3d>& got,
                const std::vector<Eigen::Vector3f>& want) {
  EXPECT_EQ(got.size(), want.size());
  double worst = 0;
  for (std::size_t i = 0; i < std::min(got.size(), want.size()); ++i)
    worst = std::max(worst, (z_up(got[i]) - want[i].cast<double>()).norm());
  return worst;
}

class MeshExports : public ::testing::Test {
 protected:
  void SetUp() override {
    store_ = db::Store::open(testing::fresh_sqlite_url());
    tiles_ = mesh_site::write_mesh_site(*store_, "m1");
  }
  std::unique_ptr<db::Store> store_;
  std::vector<mesh_site::MeshTile> tiles_;
};

TEST_F(MeshExports, TheFixtureHasTwoTilesOfSeveralLevels) {
  ASSERT_EQ(tiles_.size(), 2u);
  for (const auto& tile : tiles_) {
    EXPECT_GE(tile.levels.size(), 2u) << tile.name;
    EXPECT_EQ(tile.levels[0].mesh.triangles(), 3200u);
    for (std::size_t l = 1; l < tile.levels.size(); ++l)
      EXPECT_GT(tile.levels[l].geometric_error, 0) << tile.name << l;
  }
}

TEST_F(MeshExports, AModelWithoutAMeshIsNotFound) {
  // "barren": one tile listed without levels; "bare": no mesh_tiles at all.
  mesh_site::write_mesh_site(*store_, "barren", true, false);
  mesh_site::write_mesh_site(*store_, "bare", true, false);
  db::Document model = *store_->get("/sites/bare/model");
  model.attrs.erase("mesh_tiles");
  store_->put(model.path, model.kind, model.attrs);
  for (const std::string site : {"barren", "bare"})
    for (const char* format : {"glb", "obj", "3dtiles-mesh"}) {
      try {
        export_site(*store_, site, format);
        FAIL() << format << " exported a site without a mesh";
      } catch (const util::Error& e) {
        EXPECT_EQ(e.kind(), util::ErrorKind::kNotFound) << format;
        EXPECT_EQ(std::string(e.what()), "site " + site + " has no mesh yet")
            << format;
      }
    }
}

TEST_F(MeshExports, TheTilesetNeedsAGeoRegisteredModel) {
  mesh_site::write_mesh_site(*store_, "local", false);
  try {
    export_site(*store_, "local", "3dtiles-mesh");
    FAIL() << "a model without a geographic frame gave a tileset";
  } catch (const util::Error& e) {
    EXPECT_EQ(e.kind(), util::ErrorKind::kInvalidArgument);
  }
  // The frame-free formats do not need one.
  EXPECT_FALSE(export_site(*store_, "local", "glb").bytes.empty());
  EXPECT_FALSE(export_site(*store_, "local", "obj").bytes.empty());
}

TEST_F(MeshExports, TheGlbHoldsEveryTilesFinestLevelYUp) {
  const ExportFile file = export_site(*store_, "m1", "glb");
  EXPECT_EQ(file.content_type, "model/gltf-binary");
  EXPECT_EQ(file.filename.substr(0, 3), "m1-");
  EXPECT_EQ(file.filename.substr(file.filename.size() - 9), "-mesh.glb");
  const Json gltf = gltf_json(file.bytes);
  ASSERT_EQ(gltf["meshes"][0]["primitives"].size(), tiles_.size());
  EXPECT_EQ(gltf["images"].size(), tiles_.size());
  EXPECT_EQ(gltf["extensionsUsed"], Json::array({"KHR_materials_unlit"}));
  for (std::size_t t = 0; t < tiles_.size(); ++t)
    EXPECT_LT(farthest(gltf_positions(file.bytes, static_cast<int>(t)),
                       tiles_[t].levels[0].mesh.positions),
              1e-5);
}

TEST_F(MeshExports, TheTilesetChainsEachTilesLevelsInEcef) {
  const ExportFile file = export_site(*store_, "m1", "3dtiles-mesh");
  EXPECT_EQ(file.content_type, "application/zip");
  const auto files = unzip(file.bytes);
  const Json tileset = Json::parse(files.at("m1/tileset.json"));
  EXPECT_EQ(tileset["asset"]["version"], "1.1");
  const Json& root = tileset["root"];
  EXPECT_EQ(root["refine"], "REPLACE");
  EXPECT_FALSE(root.contains("content"));
  EXPECT_GE(tileset["geometricError"].get<double>(),
            root["geometricError"].get<double>());
  ASSERT_EQ(root["children"].size(), tiles_.size());
  std::size_t contents = 0;
  for (std::size_t t = 0; t < tiles_.size(); ++t) {
    const auto& levels = tiles_[t].levels;
    const Json* tile = &root["children"][t];
    EXPECT_LE((*tile)["geometricError"].get<double>(),
              root["geometricError"].get<double>());
    // Coarsest first, each finer level the one child of the coarser.
    for (std::size_t l = levels.size(); l-- > 0;) {
      const double error = (*tile)["geometricError"];
      EXPECT_DOUBLE_EQ(error, l == 0 ? 0.0 : levels[l].geometric_error);
      const std::string uri = (*tile)["content"]["uri"];
      EXPECT_EQ(uri,
                "tiles/" + tiles_[t].name + "-l" + std::to_string(l) + ".glb");
      ++contents;
      EXPECT_LT(farthest(gltf_positions(files.at("m1/" + uri), 0),
                         levels[l].mesh.positions),
                1e-5)
          << uri;
      if (l == 0) {
        EXPECT_FALSE(tile->contains("children"));
      } else {
        ASSERT_EQ((*tile)["children"].size(), 1u);
        tile = &(*tile)["children"][0];
      }
    }
  }
  EXPECT_EQ(files.size(), contents + 1);
  // The transform takes the site frame to ECEF.
  const Json& m = root["transform"];
  const engine::EnuFrame frame(mesh_site::kOrigin);
  const Eigen::Vector3f p = tiles_[1].levels[0].mesh.positions[77];
  const auto truth = frame.to_ecef({p.x(), p.y(), p.z()});
  for (int r = 0; r < 3; ++r)
    EXPECT_NEAR(m[r].get<double>() * p.x() + m[4 + r].get<double>() * p.y() +
                    m[8 + r].get<double>() * p.z() + m[12 + r].get<double>(),
                truth[r], 1e-3);
}

TEST_F(MeshExports, TheObjReadsBackWithItsMaterialsAndAtlases) {
  const ExportFile file = export_site(*store_, "m1", "obj");
  EXPECT_EQ(file.content_type, "application/zip");
  EXPECT_EQ(file.filename.substr(file.filename.size() - 13), "-mesh.obj.zip");
  const auto files = unzip(file.bytes);
  ASSERT_TRUE(files.count("m1/model.obj"));
  ASSERT_TRUE(files.count("m1/model.mtl"));
  std::size_t v = 0, vt = 0, vn = 0, f = 0;
  std::set<std::string> used, defined;
  std::vector<Eigen::Vector3f> first_vertices;
  std::istringstream obj(files.at("m1/model.obj"));
  for (std::string line; std::getline(obj, line);) {
    std::istringstream words(line);
    std::string tag;
    words >> tag;
    if (tag == "v") {
      Eigen::Vector3f p;
      words >> p.x() >> p.y() >> p.z();
      if (v++ < 5) first_vertices.push_back(p);
    } else if (tag == "vt") {
      ++vt;
    } else if (tag == "vn") {
      ++vn;
    } else if (tag == "usemtl") {
      std::string name;
      words >> name;
      used.insert(name);
    } else if (tag == "f") {
      ++f;
      for (std::string corner; words >> corner;) {
        std::size_t a = 0, b = 0, c = 0;
        ASSERT_EQ(std::sscanf(corner.c_str(), "%zu/%zu/%zu", &a, &b, &c), 3)
            << corner;
        EXPECT_TRUE(a >= 1 && a <= v && b >= 1 && c >= 1) << corner;
      }
    }
  }
  std::size_t vertices = 0, triangles = 0;
  for (const auto& tile : tiles_) {
    vertices += tile.levels[0].mesh.positions.size();
    triangles += tile.levels[0].mesh.triangles();
  }
  EXPECT_EQ(v, vertices);
  EXPECT_EQ(vt, vertices);
  EXPECT_EQ(vn, vertices);
  EXPECT_EQ(f, triangles);
  for (std::size_t i = 0; i < first_vertices.size(); ++i)
    EXPECT_EQ(first_vertices[i], tiles_[0].levels[0].mesh.positions[i]) << i;

  std::istringstream mtl(files.at("m1/model.mtl"));
  std::size_t atlases = 0;
  for (std::string line; std::getline(mtl, line);) {
    std::istringstream words(line);
    std::string tag, value;
    words >> tag >> value;
    if (tag == "newmtl") defined.insert(value);
    if (tag != "map_Kd") continue;
    ++atlases;
    ASSERT_TRUE(files.count("m1/" + value)) << value << " is not in the zip";
    const std::string& jpeg = files.at("m1/" + value);
    const cv::Mat atlas = cv::imdecode(
        std::vector<unsigned char>(jpeg.begin(), jpeg.end()), cv::IMREAD_COLOR);
    EXPECT_EQ(atlas.cols, 256) << value;
  }
  EXPECT_EQ(used, defined);
  EXPECT_EQ(used.size(), tiles_.size());
  EXPECT_EQ(atlases, tiles_.size());
  EXPECT_EQ(files.size(), 2 + tiles_.size());
}

TEST_F(MeshExports, TheSameModelGivesTheSameBytes) {
  for (const char* format : {"glb", "obj", "3dtiles-mesh"})
    EXPECT_EQ(export_site(*store_, "m1", format).bytes,
              export_site(*store_, "m1", format).bytes)
        << format;
}

}  // namespace
}  // namespace arscout::viewer
