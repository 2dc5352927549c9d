// 3dtiles: the cloud as a 3D Tiles 1.1 tileset (an octree of glTF point
// tiles with an ENU-to-ECEF root transform) in a zip: SITE/tileset.json and
// SITE/tiles/*.glb, for Cesium.
#include "export_support.h"
#include "point_tileset.h"
#include "zip_writer.h"

namespace arscout::viewer::formats {

extern const Exporter tiles3d;

namespace {

std::string write_tiles3d(const ExportRequest& request, std::ostream& out) {
  const SiteModel model = load_site_model(request.store, request.site);
  const engine::Geodetic origin = geographic_origin(model);
  const Cloud cloud = request.options.cloud;
  ZipWriter zip;
  // Dated by the model's commit: the same version, the same bytes.
  for (const TilesetFile& file :
       build_point_tileset(nonempty_cloud(request.store, model, cloud), origin))
    zip.add(request.site + "/" + file.path, file.bytes,
            model.updated_us / 1000000);
  put(out, zip.finish());
  return cloud_file_name(model, cloud, tiles3d, "-3dtiles");
}

}  // namespace

const Exporter tiles3d{
    "3dtiles",
    ".zip",
    "application/zip",
    "the point cloud as a 3D Tiles 1.1 tileset in a zip, for Cesium",
    true,
    false,
    &write_tiles3d};

}  // namespace arscout::viewer::formats
