// The model document's "mesh_tiles" attribute (service.h, docs/mesh.md).
#include <string>

#include "arscout/db/store.h"
#include "arscout/engine/service.h"

namespace arscout::engine {
namespace {

std::uint64_t parse_hash(const nlohmann::json& entry) {
  try {
    return std::stoull(entry.value("hash", std::string("0")));
  } catch (const std::exception&) {
    return 0;  // remade by the next mesh phase
  }
}

}  // namespace

std::vector<MeshTileEntry> mesh_tiles_of(const db::Document& model) {
  std::vector<MeshTileEntry> tiles;
  const auto attr = model.attrs.find("mesh_tiles");
  if (attr == model.attrs.end() || !attr->is_array()) return tiles;
  for (const nlohmann::json& entry : *attr) {
    MeshTileEntry tile;
    tile.tile = entry.value("tile", std::string());
    tile.hash = parse_hash(entry);
    tile.points = entry.value("points", std::size_t{0});
    tile.cell = entry.value("cell", 0.0);
    for (const nlohmann::json& level :
         entry.value("levels", nlohmann::json::array()))
      tile.levels.push_back({level.value("blob", std::string()),
                             level.value("triangles", std::size_t{0}),
                             level.value("error", 0.0)});
    if (!tile.tile.empty()) tiles.push_back(std::move(tile));
  }
  return tiles;
}

nlohmann::json mesh_tiles_json(const std::vector<MeshTileEntry>& tiles) {
  nlohmann::json out = nlohmann::json::array();
  for (const MeshTileEntry& tile : tiles) {
    nlohmann::json levels = nlohmann::json::array();
    for (const MeshTileLevel& level : tile.levels)
      levels.push_back({{"blob", level.blob},
                        {"triangles", level.triangles},
                        {"error", level.geometric_error}});
    out.push_back({{"tile", tile.tile},
                   {"hash", std::to_string(tile.hash)},
                   {"points", tile.points},
                   {"cell", tile.cell},
                   {"levels", std::move(levels)}});
  }
  return out;
}

}  // namespace arscout::engine
