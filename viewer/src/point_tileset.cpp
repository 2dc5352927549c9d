#include "point_tileset.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <unordered_set>

#include <nlohmann/json.hpp>

#include "glb_writer.h"

namespace arscout::viewer {
namespace {

using Json = nlohmann::json;
using Vec3 = std::array<double, 3>;

struct Box {
  Vec3 lo{}, hi{};
  Vec3 centre() const {
    return {(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, (lo[2] + hi[2]) / 2};
  }
  double diagonal() const {
    return std::hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
  }
  Box octant(int o) const {
    const Vec3 c = centre();
    Box b;
    for (int a = 0; a < 3; ++a) {
      const bool upper = (o >> a) & 1;
      b.lo[a] = upper ? c[a] : lo[a];
      b.hi[a] = upper ? hi[a] : c[a];
    }
    return b;
  }
  int octant_of(const engine::ColoredPoint& p) const {
    const Vec3 c = centre();
    return (p.x >= c[0] ? 1 : 0) | (p.y >= c[1] ? 2 : 0) |
           (p.z >= c[2] ? 4 : 0);
  }
};

class Builder {
 public:
  Builder(const std::vector<engine::ColoredPoint>& points,
          const PointTilesetOptions& options)
      : points_(points),
        options_(options),
        grid_(static_cast<int>(std::ceil(
            std::cbrt(static_cast<double>(options.max_tile_points))))) {}

  Json tile(std::vector<std::uint32_t> indices, const Box& box, int depth,
            const std::string& name) {
    std::vector<std::uint32_t> rest;
    double error = 0;
    if (indices.size() > options_.max_tile_points &&
        depth < options_.max_depth) {
      rest = split_sample(&indices, box);
      error = box.diagonal() / grid_;
    }
    Json node = {{"boundingVolume", {{"box", box_json(box)}}},
                 {"geometricError", error},
                 {"refine", "ADD"},
                 {"content", {{"uri", "tiles/" + name + ".glb"}}}};
    files_.push_back({"tiles/" + name + ".glb", glb_of(indices, box)});
    std::array<std::vector<std::uint32_t>, 8> octants;
    for (std::uint32_t i : rest)
      octants[box.octant_of(points_[i])].push_back(i);
    Json children = Json::array();
    for (int o = 0; o < 8; ++o)
      if (!octants[o].empty())
        children.push_back(tile(std::move(octants[o]), box.octant(o), depth + 1,
                                name + std::to_string(o)));
    if (!children.empty()) node["children"] = std::move(children);
    return node;
  }

  std::vector<TilesetFile> take_files() { return std::move(files_); }

 private:
  // Keeps in *indices one point per cell of a grid_^3 grid over `box` (a
  // sample spread over the box), and returns the others.
  std::vector<std::uint32_t> split_sample(std::vector<std::uint32_t>* indices,
                                          const Box& box) const {
    std::unordered_set<std::int64_t> taken;
    std::vector<std::uint32_t> kept, rest;
    for (std::uint32_t i : *indices) {
      const engine::ColoredPoint& p = points_[i];
      std::int64_t cell = 0;
      const double xyz[3] = {p.x, p.y, p.z};
      for (int a = 0; a < 3; ++a) {
        const double size = std::max(box.hi[a] - box.lo[a], 1e-9);
        const auto k = static_cast<std::int64_t>(
            std::clamp(std::floor((xyz[a] - box.lo[a]) / size * grid_), 0.0,
                       static_cast<double>(grid_ - 1)));
        cell = cell * grid_ + k;
      }
      (taken.insert(cell).second ? kept : rest).push_back(i);
    }
    *indices = std::move(kept);
    return rest;
  }

  static Json box_json(const Box& box) {
    const Vec3 c = box.centre();
    Vec3 h;
    for (int a = 0; a < 3; ++a)
      h[a] = std::max((box.hi[a] - box.lo[a]) / 2, 0.005);
    return {c[0], c[1], c[2], h[0], 0, 0, 0, h[1], 0, 0, 0, h[2]};
  }

  // ENU (x east, y north, z up) to glTF's y-up axes: (x, z, -y).
  std::string glb_of(const std::vector<std::uint32_t>& indices,
                     const Box& box) const {
    const Vec3 c = box.centre();
    GlbPoints glb;
    glb.translation = {c[0], c[2], -c[1]};
    for (std::uint32_t i : indices) {
      const engine::ColoredPoint& p = points_[i];
      glb.positions.push_back({static_cast<float>(p.x - c[0]),
                               static_cast<float>(p.z - c[2]),
                               static_cast<float>(-(p.y - c[1]))});
      glb.colours.push_back({p.r, p.g, p.b});
    }
    return encode_glb_points(glb);
  }

  const std::vector<engine::ColoredPoint>& points_;
  const PointTilesetOptions& options_;
  const int grid_;
  std::vector<TilesetFile> files_;
};

Box bounds_of(const std::vector<engine::ColoredPoint>& points) {
  Box box;
  box.lo = {points[0].x, points[0].y, points[0].z};
  box.hi = box.lo;
  for (const engine::ColoredPoint& p : points) {
    const double xyz[3] = {p.x, p.y, p.z};
    for (int a = 0; a < 3; ++a) {
      box.lo[a] = std::min(box.lo[a], xyz[a]);
      box.hi[a] = std::max(box.hi[a], xyz[a]);
    }
  }
  return box;
}

// ENU to ECEF, column-major as 3D Tiles writes a transform.
Json enu_to_ecef(const engine::Geodetic& origin) {
  const engine::EnuFrame frame(origin);
  const auto o = frame.to_ecef({0, 0, 0});
  Json m = Json::array();
  for (const Vec3& axis : {Vec3{1, 0, 0}, Vec3{0, 1, 0}, Vec3{0, 0, 1}}) {
    const auto p = frame.to_ecef(axis);
    m.insert(m.end(), {p[0] - o[0], p[1] - o[1], p[2] - o[2], 0.0});
  }
  m.insert(m.end(), {o[0], o[1], o[2], 1.0});
  return m;
}

}  // namespace

std::vector<TilesetFile> build_point_tileset(
    const std::vector<engine::ColoredPoint>& enu_points,
    const engine::Geodetic& origin, const PointTilesetOptions& options) {
  if (enu_points.empty())
    throw std::invalid_argument("3d tiles: the cloud has no points");
  std::vector<std::uint32_t> all(enu_points.size());
  for (std::uint32_t i = 0; i < all.size(); ++i) all[i] = i;
  const Box box = bounds_of(enu_points);
  Builder builder(enu_points, options);
  Json root = builder.tile(std::move(all), box, 0, "r");
  root["transform"] = enu_to_ecef(origin);
  const double error =
      std::max(root.at("geometricError").get<double>(), box.diagonal() / 2);
  const Json tileset = {
      {"asset", {{"version", "1.1"}, {"generator", "arscout"}}},
      {"geometricError", error},
      {"root", std::move(root)}};
  std::vector<TilesetFile> files = {{"tileset.json", tileset.dump(1)}};
  for (TilesetFile& f : builder.take_files()) files.push_back(std::move(f));
  return files;
}

}  // namespace arscout::viewer
