#include "mesh_tileset.h"

#include <algorithm>
#include <stdexcept>

namespace arscout::viewer {
namespace {

using Json = nlohmann::json;

// Half-axes at least 5 mm: a flat tile's box is not degenerate.
constexpr double kMinHalf = 0.005;

MeshBox padded(MeshBox box) {
  for (int a = 0; a < 3; ++a) {
    const double c = (box.lo[a] + box.hi[a]) / 2;
    const double h = std::max((box.hi[a] - box.lo[a]) / 2, kMinHalf);
    box.lo[a] = c - h;
    box.hi[a] = c + h;
  }
  return box;
}

Json box_json(const MeshBox& box) {
  const Eigen::Vector3d c = box.centre();
  const Eigen::Vector3d h = (box.hi - box.lo) / 2;
  return {c.x(), c.y(), c.z(), h.x(), 0, 0, 0, h.y(), 0, 0, 0, h.z()};
}

}  // namespace

void MeshBox::add(const MeshBox& other) {
  lo = lo.cwiseMin(other.lo);
  hi = hi.cwiseMax(other.hi);
}

MeshBox mesh_box(const engine::TexturedMesh& mesh) {
  MeshBox box;
  for (const Eigen::Vector3f& p : mesh.positions) {
    box.lo = box.lo.cwiseMin(p.cast<double>());
    box.hi = box.hi.cwiseMax(p.cast<double>());
  }
  return box;
}

std::vector<TilesetFile> MeshTilesetBuilder::add_tile(
    const std::string& name, const std::vector<engine::GlbMesh>& levels,
    const std::vector<double>& errors) {
  if (levels.empty() || errors.size() != levels.size())
    throw std::invalid_argument("3d tiles: mesh tile " + name + " has " +
                                std::to_string(levels.size()) + " levels and " +
                                std::to_string(errors.size()) + " errors");
  MeshBox raw;
  for (const engine::GlbMesh& level : levels) raw.add(mesh_box(level.mesh));
  const MeshBox box = padded(raw);
  engine::GlbFrame frame;
  frame.offset = box.centre();
  frame.y_up = true;  // glTF's frame; clients turn it back to z up
  std::vector<TilesetFile> files;
  Json chain;  // built from the leaf (finest) upwards
  double error = 0;
  for (std::size_t l = 0; l < levels.size(); ++l) {
    if (l > 0) error = std::max(error, errors[l]);
    const std::string uri = "tiles/" + name + "-l" + std::to_string(l) + ".glb";
    files.push_back({uri, engine::encode_glb_meshes({levels[l]}, frame)});
    Json tile = {{"boundingVolume", {{"box", box_json(box)}}},
                 {"geometricError", error},
                 {"content", {{"uri", uri}}}};
    if (l > 0) tile["children"] = Json::array({std::move(chain)});
    chain = std::move(tile);
  }
  chains_.push_back(std::move(chain));
  box_.add(box);
  largest_error_ = std::max(largest_error_, error);
  return files;
}

TilesetFile MeshTilesetBuilder::finish() const {
  if (chains_.empty())
    throw std::invalid_argument("3d tiles: the mesh has no tiles");
  const double error = std::max(largest_error_, (box_.hi - box_.lo).norm());
  Json root = {{"boundingVolume", {{"box", box_json(box_)}}},
               {"geometricError", error},
               {"refine", "REPLACE"},
               {"transform", enu_to_ecef_transform(origin_)},
               {"children", chains_}};
  const Json tileset = {
      {"asset", {{"version", "1.1"}, {"generator", "arscout"}}},
      {"geometricError", error},
      {"root", std::move(root)}};
  return {"tileset.json", tileset.dump(1)};
}

}  // namespace arscout::viewer
