#include "mesh_builder.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>

#include "dense_tiles.h"

namespace arscout::engine::service {
namespace {

using MeshTileKey = std::pair<long long, long long>;

std::string name_of(const MeshTileKey& key) {
  return dense_tile_name(key.first, key.second);
}

// Calls fn(key) for the tile of `p` and each neighbour within `margin`.
template <typename Fn>
void for_tiles_of(const ColoredPoint& p, double edge, double margin, Fn&& fn) {
  const double fx = p.x / edge, fy = p.y / edge;
  if (!std::isfinite(fx) || !std::isfinite(fy) || std::abs(fx) > 1e9 ||
      std::abs(fy) > 1e9)
    return;
  const long long ix = static_cast<long long>(std::floor(fx));
  const long long iy = static_cast<long long>(std::floor(fy));
  const double m = margin / edge;
  const int x_lo = fx - ix < m ? -1 : 0, x_hi = ix + 1 - fx < m ? 1 : 0;
  const int y_lo = fy - iy < m ? -1 : 0, y_hi = iy + 1 - fy < m ? 1 : 0;
  for (int dx = x_lo; dx <= x_hi; ++dx)
    for (int dy = y_lo; dy <= y_hi; ++dy) fn(MeshTileKey{ix + dx, iy + dy});
}

// The key views that see the tile's box, nearest first, at most `limit`.
std::vector<TextureView> views_of(
    const TexturedMesh& surface,
    const std::vector<DenseReconstruction::KeyView>& views, int limit) {
  Eigen::Vector3f lo = surface.positions.front(), hi = lo;
  for (const Eigen::Vector3f& p : surface.positions) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const Eigen::Vector3d centre = ((lo + hi) / 2).cast<double>();
  std::vector<std::pair<double, std::size_t>> seeing;
  for (std::size_t v = 0; v < views.size(); ++v) {
    const DepthMap& map = views[v].map;
    bool sees = false;
    for (int corner = 0; corner < 8 && !sees; ++corner) {
      const Eigen::Vector3d p((corner & 1 ? hi : lo).x(),
                              (corner & 2 ? hi : lo).y(),
                              (corner & 4 ? hi : lo).z());
      const Eigen::Vector3d c = map.R * p + map.t;
      if (c.z() <= 0) continue;
      const Eigen::Vector3d h = map.K * c;
      sees = h.x() / h.z() >= 0 && h.y() / h.z() >= 0 &&
             h.x() / h.z() < views[v].bgr.cols &&
             h.y() / h.z() < views[v].bgr.rows;
    }
    if (sees)
      seeing.push_back({(map.R.transpose() * -map.t - centre).norm(), v});
  }
  std::sort(seeing.begin(), seeing.end());
  if (static_cast<int>(seeing.size()) > limit) seeing.resize(limit);
  std::vector<DenseReconstruction::KeyView> nearest;
  for (const auto& [distance, v] : seeing) nearest.push_back(views[v]);
  return texture_views(nearest);
}

// One tile made: surface, texture, levels, each level's GLB stored.
MeshTileEntry make_tile(
    const MeshTileKey& key, const std::vector<ColoredPoint>& points,
    double edge, double voxel,
    const std::vector<DenseReconstruction::KeyView>& views,
    const std::function<std::string(const std::string&)>& put_blob,
    const MeshBuildOptions& options) {
  MeshTileEntry entry;
  entry.tile = name_of(key);
  const Eigen::Vector2d lo(static_cast<double>(key.first) * edge,
                           static_cast<double>(key.second) * edge);
  // The pass the published tiles had, over the tile and its margin: a
  // point the surface reads has all its neighbours in the margin, so two
  // tiles judge it alike.
  const TexturedMesh surface = mesh_surface(
      without_isolated_points(points, kIsolatedRadiusVoxels * voxel,
                              kIsolatedMinNeighbours),
      lo, lo + Eigen::Vector2d(edge, edge), voxel, options.surface);
  if (surface.empty()) return entry;
  const TexturedMesh textured = texture_mesh(
      surface, views_of(surface, views, options.max_views), options.texture);
  for (const MeshLevel& level : mesh_levels(textured, options.levels))
    entry.levels.push_back(
        {put_blob(encode_glb(level.mesh, options.jpeg_quality)),
         level.mesh.triangles(), level.geometric_error});
  return entry;
}

}  // namespace

MeshBuild update_mesh_tiles(
    const std::vector<ColoredPoint>& cloud, double edge, double voxel,
    const std::vector<MeshTileEntry>& published,
    const std::vector<DenseReconstruction::KeyView>& views,
    const std::function<std::string(const std::string& bytes)>& put_blob,
    const MeshBuildOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const double cell =
      options.surface.cell > 0 ? options.surface.cell : 2 * voxel;
  const double margin =
      (options.surface.radius_cells + 2) * cell + kIsolatedRadiusVoxels * voxel;
  std::map<MeshTileKey, std::uint64_t> hash;
  for (const ColoredPoint& p : cloud)
    for_tiles_of(p, edge, margin,
                 [&](const MeshTileKey& k) { hash[k] += dense_point_hash(p); });
  std::map<std::string, const MeshTileEntry*> before;
  for (const MeshTileEntry& e : published) before[e.tile] = &e;
  std::map<MeshTileKey, std::vector<ColoredPoint>> inputs;
  for (const auto& [key, h] : hash) {
    const auto was = before.find(name_of(key));
    if (was == before.end() || was->second->hash != h) inputs[key];
  }
  for (const ColoredPoint& p : cloud)
    for_tiles_of(p, edge, margin, [&](const MeshTileKey& k) {
      if (const auto it = inputs.find(k); it != inputs.end())
        it->second.push_back(p);
    });
  MeshBuild build;
  for (const auto& [key, h] : hash) {
    const auto input = inputs.find(key);
    MeshTileEntry entry = input == inputs.end()
                              ? *before.at(name_of(key))
                              : make_tile(key, input->second, edge, voxel,
                                          views, put_blob, options);
    build.remade += input != inputs.end();
    entry.hash = h;
    if (entry.levels.empty()) continue;
    build.triangles += entry.levels.front().triangles;
    build.tiles.push_back(std::move(entry));
  }
  build.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
          .count();
  return build;
}

}  // namespace arscout::engine::service
