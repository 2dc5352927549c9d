// ecef-ply: the cloud as binary PLY in ECEF (WGS84, EPSG:4978), double x y
// z and uchar rgb, for GIS tools.
#include <bit>
#include <cstring>
#include <sstream>
#include <stdexcept>

#include "arscout/viewer/exports.h"
#include "export_support.h"

namespace arscout::viewer {

std::string encode_ecef_ply(const std::vector<engine::ColoredPoint>& points,
                            const engine::Geodetic& origin,
                            const std::string& comment) {
  if (comment.find('\n') != std::string::npos)
    throw std::invalid_argument("ecef ply: the comment holds a line break");
  std::ostringstream header;
  header << "ply\nformat binary_little_endian 1.0\ncomment " << comment
         << "\nelement vertex " << points.size()
         << "\nproperty double x\nproperty double y\nproperty double z\n"
            "property uchar red\nproperty uchar green\nproperty uchar blue\n"
            "end_header\n";
  std::string out = header.str();
  const size_t start = out.size();
  constexpr size_t kStride = 3 * sizeof(double) + 3;
  out.resize(start + points.size() * kStride);
  const engine::EnuFrame frame(origin);
  char* at = out.data() + start;
  for (const engine::ColoredPoint& p : points) {
    const std::array<double, 3> ecef = frame.to_ecef({p.x, p.y, p.z});
    // x86 and ARM hosts are little-endian, as the header says.
    static_assert(std::endian::native == std::endian::little);
    std::memcpy(at, ecef.data(), 3 * sizeof(double));
    at[24] = static_cast<char>(p.r);
    at[25] = static_cast<char>(p.g);
    at[26] = static_cast<char>(p.b);
    at += kStride;
  }
  return out;
}

namespace formats {

extern const Exporter ecef_ply;

namespace {

std::string write_ecef_ply(const ExportRequest& request, std::ostream& out) {
  const SiteModel model = load_site_model(request.store, request.site);
  const engine::Geodetic origin = geographic_origin(model);
  const Cloud cloud = request.options.cloud;
  const std::string comment = "arscout site " + request.site + " model v" +
                              std::to_string(model.version) + " " +
                              cloud_name(model, cloud) +
                              " cloud; frame ECEF WGS84 (EPSG:4978), metres";
  put(out, encode_ecef_ply(load_cloud(request.store, model, cloud), origin,
                           comment));
  return cloud_file_name(model, cloud, ecef_ply, "-ecef");
}

}  // namespace

const Exporter ecef_ply{
    "ecef-ply",
    ".ply",
    "application/x-ply",
    "the point cloud as binary PLY in ECEF (EPSG:4978), for GIS tools",
    true,
    false,
    &write_ecef_ply};

}  // namespace formats
}  // namespace arscout::viewer
