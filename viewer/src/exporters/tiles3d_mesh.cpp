// 3dtiles-mesh: the textured mesh as a 3D Tiles 1.1 tileset (per mesh tile
// a chain of its levels of detail, refined by replacement; glTF contents;
// an ENU-to-ECEF root transform) in a zip: SITE/tiles/*.glb and
// SITE/tileset.json, for Cesium and other 3D Tiles clients (docs/mesh.md,
// "Exports").
#include "export_support.h"
#include "mesh_tileset.h"
#include "zip_writer.h"

namespace arscout::viewer::formats {

extern const Exporter tiles3d_mesh;

namespace {

std::string write_tiles3d_mesh(const ExportRequest& request,
                               std::ostream& out) {
  const SiteModel model = load_site_model(request.store, request.site);
  const engine::Geodetic origin = geographic_origin(model);
  const std::vector<engine::MeshTileEntry> tiles = nonempty_mesh_tiles(model);
  MeshTilesetBuilder builder(origin);
  ZipWriter zip;
  // Dated by the model's commit: the same version, the same bytes.
  const std::int64_t mtime = model.updated_us / 1000000;
  for (const engine::MeshTileEntry& tile : tiles) {
    std::vector<engine::GlbMesh> levels;
    std::vector<double> errors;
    for (std::size_t l = 0; l < tile.levels.size(); ++l) {
      levels.push_back(load_mesh_level(request.store, model, tile, l));
      errors.push_back(tile.levels[l].geometric_error);
    }
    for (const TilesetFile& file : builder.add_tile(tile.tile, levels, errors))
      zip.add(request.site + "/" + file.path, file.bytes, mtime);
  }
  const TilesetFile tileset = builder.finish();
  zip.add(request.site + "/" + tileset.path, tileset.bytes, mtime);
  put(out, zip.finish());
  return versioned_name(model, "mesh-3dtiles", tiles3d_mesh.extension);
}

}  // namespace

const Exporter tiles3d_mesh{
    "3dtiles-mesh",
    ".zip",
    "application/zip",
    "the textured mesh as a 3D Tiles 1.1 tileset in a zip (levels of "
    "detail, glTF tiles), for Cesium",
    false,
    false,
    &write_tiles3d_mesh};

}  // namespace arscout::viewer::formats
