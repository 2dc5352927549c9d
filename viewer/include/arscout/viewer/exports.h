// A site's model in standard files (docs/frames.md explains the frames).
// The formats are the registry's (exporter.h: exporters()), each in one
// file of viewer/src/exporters/; export_site runs one into bytes, for the
// CLI and the API. The encoders that the tests check alone are declared
// here too.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <string_view>

#include "arscout/db/store.h"
#include "arscout/viewer/exporter.h"
#include "arscout/viewer/site_model.h"

namespace arscout::viewer {

struct ExportFile {
  std::string filename;      // SITE-vVERSION-...EXT
  std::string content_type;  // for HTTP
  std::string bytes;
};

// The site's current model in `format`, a name of exporters(). Throws
// util::Error kInvalidArgument for a name that is not a format (the message
// lists the formats), and what Exporter::write throws: kNotFound without a
// model; kInvalidArgument for a geographic format on a model that is not
// geo-registered (its frame is arbitrary, so there is no honest geography to
// give) and for a CRS or heights option that does not fit the site (the
// message says why).
ExportFile export_site(db::Store& store, const std::string& site,
                       std::string_view format, const ExportOptions& options);
ExportFile export_site(db::Store& store, const std::string& site,
                       std::string_view format, Cloud cloud = Cloud::kDense);
ExportFile export_site(db::Store& store, const std::string& site,
                       const Exporter& format, const ExportOptions& options);

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
