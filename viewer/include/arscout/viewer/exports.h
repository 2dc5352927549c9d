// A site's model in standard files (docs/frames.md explains the frames):
//
//   ply       binary PLY in the site's ENU frame (float x y z, uchar rgb),
//             the dense cloud when there is one, else the sparse one
//   colmap    the COLMAP text model (cameras.txt, images.txt, points3D.txt
//             in a folder SITE/) as a tar; world frame: the site's ENU
//   geocsv    image,latitude,longitude,altitude: each registered camera's
//             centre on WGS84 (ellipsoidal height)
//   ecef-ply  the cloud as binary PLY in ECEF (WGS84, EPSG:4978), double
//             x y z and uchar rgb, for GIS tools
//   las       the cloud as LAS 1.4 (point format 7: millimetre integers,
//             16-bit RGB) in the chosen CRS (ExportOptions), its OGC WKT
//             in the file
//   3dtiles   the cloud as a 3D Tiles 1.1 tileset (an octree of glTF point
//             tiles with an ENU-to-ECEF root transform) in a zip: SITE/
//             tileset.json and SITE/tiles/*.glb, for Cesium
//   geojson   the registered cameras as GeoJSON points (WGS84) with their
//             heading and pitch, for web maps: the bytes of GET
//             /v1/sites/{id}/cameras.geojson
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>

#include "arscout/db/store.h"
#include "arscout/viewer/site_model.h"

namespace arscout::viewer {

enum class ExportFormat {
  kPly,
  kColmap,
  kGeoCsv,
  kEcefPly,
  kLas,
  k3dTiles,
  kGeoJson
};

// "ply" | "colmap" | "geocsv" | "ecef-ply" | "las" | "3dtiles" | "geojson";
// nullopt otherwise.
std::optional<ExportFormat> parse_export_format(const std::string& name);
const char* to_string(ExportFormat format);

struct ExportFile {
  std::string filename;      // SITE-vVERSION.EXT
  std::string content_type;  // for HTTP
  std::string bytes;
};

struct ExportOptions {
  Cloud cloud = Cloud::kDense;  // ply, ecef-ply, las, 3dtiles
  // las: the output CRS, "utm" (the site's zone) or "EPSG:N", and the
  // heights, "ellipsoid" or "egm96" (docs/frames.md).
  std::string crs = "utm";
  std::string heights = "ellipsoid";
};

// Throws util::Error: kNotFound without a model; kInvalidArgument for
// geocsv, ecef-ply, las, 3dtiles or geojson on a model that is not
// geo-registered (its frame is arbitrary, so there is no honest geography to
// give), and for a CRS or heights option that does not fit the site (the
// message says why).
ExportFile export_site(db::Store& store, const std::string& site,
                       ExportFormat format, const ExportOptions& options);
ExportFile export_site(db::Store& store, const std::string& site,
                       ExportFormat format, Cloud cloud = Cloud::kDense);

// The LAS file's bytes for points given in the ENU frame at `origin`, in
// options.crs with options.heights, dated `created_us` (microseconds since
// 1970). Throws std::invalid_argument for a CRS or heights option that does
// not fit `origin`, saying why.
std::string encode_site_las(const std::vector<engine::ColoredPoint>& points,
                            const engine::Geodetic& origin,
                            const ExportOptions& options,
                            std::int64_t created_us);

// The ECEF PLY's bytes for points given in the ENU frame at `origin`.
std::string encode_ecef_ply(const std::vector<engine::ColoredPoint>& points,
                            const engine::Geodetic& origin,
                            const std::string& comment);

// A point of the site's ENU frame in an output CRS (the viewer's picked
// point): its WGS84 position and its coordinates in `crs` with `heights`
// (as ExportOptions). Throws util::Error kNotFound without a model,
// kInvalidArgument when the model is not geo-registered or the CRS does not
// fit the site.
struct SitePoint {
  std::array<double, 3> enu{};
  engine::Geodetic wgs84;
  std::string crs_code;  // "EPSG:32632", "EPSG:32632+5773"
  std::string crs_name;  // PROJ's name of it
  bool geographic = false;
  // Easting, northing (metres) or longitude, latitude (degrees), then height.
  std::array<double, 3> xyz{};
};
SitePoint project_site_point(db::Store& store, const std::string& site,
                             const std::array<double, 3>& enu,
                             const std::string& crs = "utm",
                             const std::string& heights = "ellipsoid");

}  // namespace arscout::viewer
