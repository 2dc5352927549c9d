// Writes a site whose model holds a synthetic textured mesh
// (synthetic_mesh_site.h), for mesh_export_test.sh: the exports are made
// from it by `arscout export`, as a user gets them.
//   make_mesh_site DB_URL SITE [OUT_DIR]
// OUT_DIR (made if missing): each stored level's GLB as TILE-lLEVEL.glb,
// and finest_ecef.json, {"vertices": [x, y, z, ...]}, the finest levels'
// vertices in ECEF (metres, WGS84) from the site's ENU origin, for the
// browser check of where the tiles land.
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "arscout/db/store.h"
#include "synthetic_mesh_site.h"

namespace {

void write_file(const std::filesystem::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out << bytes;
  if (!out) throw std::runtime_error("cannot write " + path.string());
}

void write_outputs(const std::filesystem::path& dir,
                   const std::vector<mesh_site::MeshTile>& tiles) {
  std::filesystem::create_directories(dir);
  nlohmann::json vertices = nlohmann::json::array();
  const arscout::engine::EnuFrame frame(mesh_site::kOrigin);
  for (const mesh_site::MeshTile& tile : tiles) {
    for (std::size_t l = 0; l < tile.glbs.size(); ++l)
      write_file(dir / (tile.name + "-l" + std::to_string(l) + ".glb"),
                 tile.glbs[l]);
    for (const Eigen::Vector3f& p : tile.levels[0].mesh.positions)
      for (double v : frame.to_ecef({p.x(), p.y(), p.z()}))
        vertices.push_back(v);
  }
  write_file(dir / "finest_ecef.json",
             nlohmann::json{{"vertices", vertices}}.dump());
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3 && argc != 4) {
    std::fprintf(stderr, "usage: make_mesh_site DB_URL SITE [OUT_DIR]\n");
    return 2;
  }
  try {
    auto store = arscout::db::Store::open(argv[1]);
    const auto tiles = mesh_site::write_mesh_site(*store, argv[2]);
    if (argc == 4) write_outputs(argv[3], tiles);
    for (const mesh_site::MeshTile& tile : tiles)
      std::printf("site %s: mesh tile %s, %zu levels, %zu triangles\n", argv[2],
                  tile.name.c_str(), tile.levels.size(),
                  tile.levels[0].mesh.triangles());
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "make_mesh_site: %s\n", e.what());
    return 1;
  }
}
