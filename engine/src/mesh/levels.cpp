// Levels of detail by quadric edge collapse (meshoptimizer's simplifier).
#include <algorithm>
#include <cstdint>
#include <limits>
#include <vector>

#include <meshoptimizer.h>

#include "arscout/engine/mesh.h"

namespace arscout::engine {
namespace {

// The vertices `indices` use, in their first-use order, with the indices
// renumbered to match.
TexturedMesh compact(const TexturedMesh& mesh,
                     const std::vector<std::uint32_t>& indices) {
  constexpr std::uint32_t kUnused = std::numeric_limits<std::uint32_t>::max();
  std::vector<std::uint32_t> remap(mesh.positions.size(), kUnused);
  TexturedMesh out;
  out.atlas = mesh.atlas;
  out.indices.reserve(indices.size());
  for (const std::uint32_t old : indices) {
    if (remap[old] == kUnused) {
      remap[old] = static_cast<std::uint32_t>(out.positions.size());
      out.positions.push_back(mesh.positions[old]);
      if (!mesh.normals.empty()) out.normals.push_back(mesh.normals[old]);
      if (!mesh.colors.empty()) out.colors.push_back(mesh.colors[old]);
      if (!mesh.uvs.empty()) out.uvs.push_back(mesh.uvs[old]);
    }
    out.indices.push_back(remap[old]);
  }
  return out;
}

}  // namespace

std::vector<MeshLevel> mesh_levels(const TexturedMesh& mesh, int levels) {
  std::vector<MeshLevel> out;
  if (mesh.empty() || levels <= 0) return out;
  out.push_back({mesh, 0.0});
  const float* positions = mesh.positions.front().data();
  const std::size_t stride = sizeof(Eigen::Vector3f);
  const float scale =
      meshopt_simplifyScale(positions, mesh.positions.size(), stride);
  std::vector<std::uint32_t> indices = mesh.indices;
  while (static_cast<int>(out.size()) < levels) {
    const std::size_t target = indices.size() / 4 / 3 * 3;
    if (target / 3 < 64) break;
    std::vector<std::uint32_t> simpler(indices.size());
    float error = 0;
    // Any error the target count needs (1: the whole extent): the level's
    // error is reported, not bounded; the border stays so tiles still meet.
    simpler.resize(meshopt_simplify(simpler.data(), indices.data(),
                                    indices.size(), positions,
                                    mesh.positions.size(), stride, target, 1.0f,
                                    meshopt_SimplifyLockBorder, &error));
    if (simpler.size() / 3 < 64 || simpler.size() >= indices.size()) break;
    indices = simpler;
    const double previous = out.back().geometric_error;
    out.push_back({compact(mesh, indices),
                   std::max(previous, static_cast<double>(error * scale))});
  }
  return out;
}

}  // namespace arscout::engine
