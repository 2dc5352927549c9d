#include "point_tileset.h"

#include <algorithm>
#include <array>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "glb_writer.h"
#include "point_octree.h"

namespace arscout::viewer {
namespace {

using Json = nlohmann::json;
using Vec3 = std::array<double, 3>;

class TilesetWriter {
 public:
  TilesetWriter(const std::vector<engine::ColoredPoint>& points,
                const std::vector<OctreeNode>& nodes)
      : points_(points), nodes_(nodes) {}

  // The tile of nodes_[at] and, below it, its children's; adds their glbs.
  Json tile(std::size_t at) {
    const OctreeNode& node = nodes_[at];
    Json json = {{"boundingVolume", {{"box", box_json(node.box)}}},
                 {"geometricError", node.spacing},
                 {"refine", "ADD"},
                 {"content", {{"uri", "tiles/" + node.name + ".glb"}}}};
    files_.push_back({"tiles/" + node.name + ".glb", glb_of(node)});
    Json children = Json::array();
    for (std::size_t child : node.children) children.push_back(tile(child));
    if (!children.empty()) json["children"] = std::move(children);
    return json;
  }

  std::vector<TilesetFile> take_files() { return std::move(files_); }

 private:
  static Json box_json(const OctreeBox& box) {
    const Vec3 c = box.centre();
    Vec3 h;
    for (int a = 0; a < 3; ++a)
      h[a] = std::max((box.hi[a] - box.lo[a]) / 2, 0.005);
    return {c[0], c[1], c[2], h[0], 0, 0, 0, h[1], 0, 0, 0, h[2]};
  }

  // ENU (x east, y north, z up) to glTF's y-up axes: (x, z, -y).
  std::string glb_of(const OctreeNode& node) const {
    const Vec3 c = node.box.centre();
    GlbPoints glb;
    glb.translation = {c[0], c[2], -c[1]};
    for (std::uint32_t i : node.points) {
      const engine::ColoredPoint& p = points_[i];
      glb.positions.push_back({static_cast<float>(p.x - c[0]),
                               static_cast<float>(p.z - c[2]),
                               static_cast<float>(-(p.y - c[1]))});
      glb.colours.push_back({p.r, p.g, p.b});
    }
    return encode_glb_points(glb);
  }

  const std::vector<engine::ColoredPoint>& points_;
  const std::vector<OctreeNode>& nodes_;
  std::vector<TilesetFile> files_;
};

}  // namespace

std::array<double, 16> enu_to_ecef_transform(const engine::Geodetic& origin) {
  const engine::EnuFrame frame(origin);
  const auto o = frame.to_ecef({0, 0, 0});
  std::array<double, 16> m{};
  int at = 0;
  for (const Vec3& axis : {Vec3{1, 0, 0}, Vec3{0, 1, 0}, Vec3{0, 0, 1}}) {
    const auto p = frame.to_ecef(axis);
    for (int r = 0; r < 3; ++r) m[at++] = p[r] - o[r];
    m[at++] = 0.0;
  }
  for (int r = 0; r < 3; ++r) m[at++] = o[r];
  m[at] = 1.0;
  return m;
}

std::vector<TilesetFile> build_point_tileset(
    const std::vector<engine::ColoredPoint>& enu_points,
    const engine::Geodetic& origin, const PointTilesetOptions& options) {
  if (enu_points.empty())
    throw std::invalid_argument("3d tiles: the cloud has no points");
  const std::vector<OctreeNode> nodes = build_point_octree(
      enu_points, {options.max_tile_points, options.max_depth});
  TilesetWriter writer(enu_points, nodes);
  Json root = writer.tile(0);
  root["transform"] = enu_to_ecef_transform(origin);
  const double error = std::max(root.at("geometricError").get<double>(),
                                nodes[0].box.diagonal() / 2);
  const Json tileset = {
      {"asset", {{"version", "1.1"}, {"generator", "arscout"}}},
      {"geometricError", error},
      {"root", std::move(root)}};
  std::vector<TilesetFile> files = {{"tileset.json", tileset.dump(1)}};
  for (TilesetFile& f : writer.take_files()) files.push_back(std::move(f));
  return files;
}

}  // namespace arscout::viewer
