#include "mesh/surface_cleanup.h"

#include <cstdint>
#include <limits>
#include <numeric>
#include <vector>

#include <Eigen/Geometry>

namespace arscout::engine::mesh {
namespace {

class DisjointSets {
 public:
  explicit DisjointSets(std::size_t n) : parent_(n) {
    std::iota(parent_.begin(), parent_.end(), 0u);
  }
  std::uint32_t find(std::uint32_t x) {
    while (parent_[x] != x) x = parent_[x] = parent_[parent_[x]];
    return x;
  }
  void join(std::uint32_t a, std::uint32_t b) { parent_[find(a)] = find(b); }

 private:
  std::vector<std::uint32_t> parent_;
};

// Keeps the vertices `keep` marks, renumbering the triangles.
void keep_vertices(TexturedMesh& mesh, const std::vector<bool>& keep) {
  constexpr auto kGone = std::numeric_limits<std::uint32_t>::max();
  std::vector<std::uint32_t> remap(mesh.positions.size(), kGone);
  std::uint32_t next = 0;
  for (std::size_t v = 0; v < keep.size(); ++v) {
    if (!keep[v]) continue;
    remap[v] = next;
    mesh.positions[next] = mesh.positions[v];
    if (!mesh.normals.empty()) mesh.normals[next] = mesh.normals[v];
    if (!mesh.colors.empty()) mesh.colors[next] = mesh.colors[v];
    if (!mesh.uvs.empty()) mesh.uvs[next] = mesh.uvs[v];
    ++next;
  }
  mesh.positions.resize(next);
  if (!mesh.normals.empty()) mesh.normals.resize(next);
  if (!mesh.colors.empty()) mesh.colors.resize(next);
  if (!mesh.uvs.empty()) mesh.uvs.resize(next);
  std::vector<std::uint32_t> indices;
  indices.reserve(mesh.indices.size());
  for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    const std::uint32_t a = remap[mesh.indices[t]],
                        b = remap[mesh.indices[t + 1]],
                        c = remap[mesh.indices[t + 2]];
    if (a == kGone || b == kGone || c == kGone) continue;
    indices.insert(indices.end(), {a, b, c});
  }
  mesh.indices = std::move(indices);
}

}  // namespace

void drop_small_pieces(
    TexturedMesh& mesh, double min_area,
    const std::function<bool(const Eigen::Vector3f&)>& on_column_border) {
  const std::size_t n = mesh.positions.size();
  DisjointSets sets(n);
  for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    sets.join(mesh.indices[t], mesh.indices[t + 1]);
    sets.join(mesh.indices[t], mesh.indices[t + 2]);
  }
  std::vector<double> area(n, 0);
  std::vector<bool> border(n, false);
  const auto& p = mesh.positions;
  for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    const Eigen::Vector3f& a = p[mesh.indices[t]];
    area[sets.find(mesh.indices[t])] +=
        0.5 * static_cast<double>((p[mesh.indices[t + 1]] - a)
                                      .cross(p[mesh.indices[t + 2]] - a)
                                      .norm());
  }
  for (std::uint32_t v = 0; v < n; ++v)
    if (on_column_border(mesh.positions[v])) border[sets.find(v)] = true;
  std::vector<bool> keep(n, false);
  std::vector<bool> used(n, false);
  for (const std::uint32_t v : mesh.indices) used[v] = true;
  for (std::uint32_t v = 0; v < n; ++v) {
    const std::uint32_t root = sets.find(v);
    keep[v] = used[v] && (border[root] || area[root] >= min_area);
  }
  keep_vertices(mesh, keep);
}

}  // namespace arscout::engine::mesh
