// glb: the textured mesh as one binary glTF 2.0 file: every mesh tile's
// finest level as one primitive with its own atlas and unlit material,
// turned into glTF's y-up frame (x east, y up, z south; metres from the
// site's origin, which the node's translation keeps; docs/mesh.md,
// "Exports"), for Blender, three.js and other glTF viewers.
#include "export_support.h"

namespace arscout::viewer::formats {

extern const Exporter glb;

namespace {

std::string write_glb(const ExportRequest& request, std::ostream& out) {
  const SiteModel model = load_site_model(request.store, request.site);
  std::vector<engine::GlbMesh> meshes;
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(1e30f), hi = -lo;
  for (const engine::MeshTileEntry& tile : nonempty_mesh_tiles(model)) {
    meshes.push_back(load_mesh_level(request.store, model, tile, 0));
    for (const Eigen::Vector3f& p : meshes.back().mesh.positions) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
  }
  engine::GlbFrame frame;
  // Positions relative to the mesh's centre keep floats precise.
  frame.offset = ((lo + hi) / 2).cast<double>();
  frame.y_up = true;
  put(out, engine::encode_glb_meshes(meshes, frame));
  return versioned_name(model, "mesh", glb.extension);
}

}  // namespace

const Exporter glb{"glb",
                   ".glb",
                   "model/gltf-binary",
                   "the textured mesh (finest level) as one binary glTF, y up",
                   false,
                   false,
                   &write_glb};

}  // namespace arscout::viewer::formats
