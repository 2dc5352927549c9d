// The texture atlas (texture_mesh's second step): faces of one view that
// share an edge form a patch; each patch's footprint in its photo is
// copied into one atlas (shelf-packed, all scaled down together to fit)
// with its colour levelled toward its neighbours' at the seams.
#pragma once

#include <cstdint>
#include <vector>

#include "arscout/engine/mesh.h"

namespace arscout::engine::mesh {

// `mesh` (positions, normals, colours, indices) rebuilt with texture
// coordinates into a new atlas; `labels` gives each face's view (-1: none,
// a flat texel of its vertices' mean colour).
TexturedMesh build_atlas(
    const TexturedMesh& mesh, const std::vector<int>& labels,
    const std::vector<std::vector<std::uint32_t>>& neighbours,
    const std::vector<TextureView>& views, const TextureOptions& options);

}  // namespace arscout::engine::mesh
