#include "synthetic_mesh_site.h"

#include <cmath>

#include <nlohmann/json.hpp>

#include "arscout/documents/model.h"
#include "arscout/documents/site.h"
#include "arscout/engine/service.h"

namespace mesh_site {
namespace {

using arscout::engine::TexturedMesh;

constexpr double kStep = 0.25, kSide = 10;
constexpr int kAtlas = 256;

double height(double x, double y) {
  return 2 + 1.5 * std::sin(x / 2.5) * std::cos(y / 3) + 0.1 * x;
}

Eigen::Vector3f normal_at(double x, double y) {
  const double dx = 1.5 / 2.5 * std::cos(x / 2.5) * std::cos(y / 3) + 0.1;
  const double dy = -1.5 / 3 * std::sin(x / 2.5) * std::sin(y / 3);
  return Eigen::Vector3d(-dx, -dy, 1).normalized().cast<float>();
}

// The tile's atlas: 1 m squares in two colours (BGR), row 0 at the tile's
// north edge (texture coordinates from the top left, as glTF has them).
cv::Mat checker_atlas(const cv::Vec3b& a, const cv::Vec3b& b) {
  cv::Mat atlas(kAtlas, kAtlas, CV_8UC3);
  for (int r = 0; r < kAtlas; ++r)
    for (int c = 0; c < kAtlas; ++c) {
      const int square = (c * 10 / kAtlas) + (r * 10 / kAtlas);
      atlas.at<cv::Vec3b>(r, c) = square % 2 ? a : b;
    }
  return atlas;
}

TexturedMesh patch(double x0, const cv::Mat& atlas) {
  TexturedMesh mesh;
  mesh.atlas = atlas;
  const int n = static_cast<int>(kSide / kStep) + 1;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const double x = x0 + i * kStep, y = j * kStep;
      mesh.positions.emplace_back(x, y, height(x, y));
      mesh.normals.push_back(normal_at(x, y));
      const float u = static_cast<float>(i) / (n - 1);
      const float v = 1 - static_cast<float>(j) / (n - 1);
      mesh.uvs.emplace_back(u, v);
      const cv::Vec3b bgr = atlas.at<cv::Vec3b>(
          std::min(kAtlas - 1, static_cast<int>(v * kAtlas)),
          std::min(kAtlas - 1, static_cast<int>(u * kAtlas)));
      mesh.colors.push_back({bgr[2], bgr[1], bgr[0]});
    }
  // Counter-clockwise seen from above, where the normals point.
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      const std::uint32_t a = j * n + i, b = a + 1, c = a + n, d = c + 1;
      mesh.indices.insert(mesh.indices.end(), {a, b, d, a, d, c});
    }
  return mesh;
}

}  // namespace

std::vector<TexturedMesh> synthetic_mesh_tiles() {
  return {patch(0, checker_atlas({40, 110, 230}, {200, 200, 60})),
          patch(kSide, checker_atlas({60, 200, 60}, {220, 80, 160}))};
}

std::vector<MeshTile> write_mesh_site(arscout::db::Store& store,
                                      const std::string& site,
                                      bool geo_registered, bool with_mesh) {
  std::vector<MeshTile> tiles;
  std::vector<arscout::engine::MeshTileEntry> entries;
  const char* names[] = {"0_0", "1_0"};
  const std::vector<TexturedMesh> meshes =
      with_mesh ? synthetic_mesh_tiles() : std::vector<TexturedMesh>{};
  for (std::size_t t = 0; t < meshes.size(); ++t) {
    MeshTile tile{names[t], arscout::engine::mesh_levels(meshes[t]), {}};
    arscout::engine::MeshTileEntry entry{tile.name, 1000 + t, 0, 0, {}};
    for (const arscout::engine::MeshLevel& level : tile.levels) {
      tile.glbs.push_back(arscout::engine::encode_glb(level.mesh));
      entry.levels.push_back({store.put_blob(tile.glbs.back()),
                              level.mesh.triangles(), level.geometric_error});
    }
    tiles.push_back(std::move(tile));
    entries.push_back(std::move(entry));
  }
  arscout::documents::ModelDocument model;
  model.site = site;
  model.geo_registered = geo_registered;
  const arscout::documents::GeoPoint origin{kOrigin.lat, kOrigin.lon,
                                            kOrigin.alt};
  if (geo_registered) model.enu_origin = origin;
  nlohmann::json attrs = to_json(model);
  // A third tile whose points made no surface: listed, without levels.
  entries.push_back({"5_5", 2000, 0, 0, {}});
  attrs["mesh_tiles"] = arscout::engine::mesh_tiles_json(entries);
  const std::int64_t version =
      store.put("/sites/" + site + "/model", "model", attrs).version;
  arscout::documents::Site doc;
  doc.name = "synthetic mesh " + site;
  doc.radius_m = 50;
  doc.centre = origin;
  doc.model_version = version;
  doc.state = "modelled";
  store.put("/sites/" + site, "site", to_json(doc));
  return tiles;
}

}  // namespace mesh_site
