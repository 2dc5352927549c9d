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
#pragma once

#include <optional>
#include <string>

#include "arscout/db/store.h"
#include "arscout/viewer/site_model.h"

namespace arscout::viewer {

enum class ExportFormat { kPly, kColmap, kGeoCsv, kEcefPly };

// "ply" | "colmap" | "geocsv" | "ecef-ply"; nullopt otherwise.
std::optional<ExportFormat> parse_export_format(const std::string& name);
const char* to_string(ExportFormat format);

struct ExportFile {
  std::string filename;      // SITE-vVERSION.EXT
  std::string content_type;  // for HTTP
  std::string bytes;
};

// Throws db::StoreError: kNotFound without a model; kInvalidArgument for
// geocsv or ecef-ply on a model that is not geo-registered (its frame is
// arbitrary, so there is no honest geography to give).
ExportFile export_site(db::Store& store, const std::string& site,
                       ExportFormat format, Cloud cloud = Cloud::kDense);

// The ECEF PLY's bytes for points given in the ENU frame at `origin`.
std::string encode_ecef_ply(const std::vector<engine::ColoredPoint>& points,
                            const engine::Geodetic& origin,
                            const std::string& comment);

}  // namespace arscout::viewer
