// texture_mesh: views chosen per face, then the atlas (docs/mesh.md).
#include "arscout/engine/mesh.h"
#include "mesh/atlas.h"
#include "mesh/view_selection.h"

namespace arscout::engine {

std::vector<TextureView> texture_views(
    const std::vector<DenseReconstruction::KeyView>& key_views) {
  std::vector<TextureView> views;
  for (const DenseReconstruction::KeyView& v : key_views)
    views.push_back({v.map.id, v.bgr, v.map.K, v.map.R, v.map.t, v.map.depth});
  return views;
}

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
