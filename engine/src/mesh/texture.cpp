// texture_mesh: views chosen per face, then the atlas (docs/mesh.md).
#include "arscout/engine/mesh.h"
#include "mesh/atlas.h"
#include "mesh/view_selection.h"

namespace arscout::engine {

TexturedMesh texture_mesh(const TexturedMesh& surface,
                          const std::vector<TextureView>& views,
                          const TextureOptions& options) {
  if (surface.empty()) return surface;
  const auto neighbours =
      mesh::face_neighbours(surface.indices, surface.positions.size());
  const std::vector<int> labels =
      mesh::select_views(surface, views, neighbours, options);
  return mesh::build_atlas(surface, labels, neighbours, views, options);
}

}  // namespace arscout::engine
