// Which photo textures each face (texture_mesh's first step): per view, the
// faces it sees unhidden and squarely enough, scored by their area in its
// pixels; then rounds that hand a face its neighbours' view when that view
// sees it nearly as well.
#pragma once

#include <cstdint>
#include <vector>

#include "arscout/engine/mesh.h"

namespace arscout::engine::mesh {

// Faces sharing an edge, per face (at most three each).
std::vector<std::vector<std::uint32_t>> face_neighbours(
    const std::vector<std::uint32_t>& indices, std::size_t vertices);

// The view (index into `views`) of each face, -1 when none sees it.
std::vector<int> select_views(
    const TexturedMesh& mesh, const std::vector<TextureView>& views,
    const std::vector<std::vector<std::uint32_t>>& neighbours,
    const TextureOptions& options);

}  // namespace arscout::engine::mesh
