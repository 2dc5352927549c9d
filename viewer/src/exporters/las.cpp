// las: the cloud as LAS 1.4 (point format 7: millimetre integers, 16-bit
// RGB) in the chosen CRS and heights (ExportOptions), its OGC WKT in the
// file.
#include <chrono>
#include <stdexcept>

#include "arscout/util/error.h"
#include "arscout/viewer/exports.h"
#include "export_support.h"
#include "las_writer.h"
#include "output_crs.h"

namespace arscout::viewer {

std::string encode_site_las(const std::vector<engine::ColoredPoint>& points,
                            const engine::Geodetic& origin,
                            const ExportOptions& options,
                            std::int64_t created_us) {
  const OutputCrs crs(options.crs, options.heights, origin);
  const engine::EnuFrame frame(origin);
  std::vector<LasPoint> las_points;
  las_points.reserve(points.size());
  for (const engine::ColoredPoint& p : points) {
    LasPoint point;
    point.xyz = crs.from_geodetic(frame.to_geodetic({p.x, p.y, p.z}));
    point.red = static_cast<std::uint16_t>(p.r * 257);
    point.green = static_cast<std::uint16_t>(p.g * 257);
    point.blue = static_cast<std::uint16_t>(p.b * 257);
    point.support = p.support;
    point.normal = {p.nx, p.ny, p.nz};
    point.score = p.score;
    las_points.push_back(point);
  }
  LasFile file;
  file.wkt = crs.wkt();
  // 1e-8 degrees is about 1.1 mm on the ground.
  file.xy_scale = crs.geographic() ? 1e-8 : 0.001;
  file.software = "arscout " ARSCOUT_VERSION_STRING;
  const std::chrono::sys_days day = std::chrono::floor<std::chrono::days>(
      std::chrono::sys_time<std::chrono::microseconds>(
          std::chrono::microseconds(created_us)));
  const std::chrono::year_month_day date(day);
  file.year = static_cast<int>(date.year());
  file.day_of_year =
      (day - std::chrono::sys_days(date.year() / std::chrono::January / 1))
          .count() +
      1;
  return encode_las(las_points, file);
}

namespace formats {

extern const Exporter las;

namespace {

std::string write_las(const ExportRequest& request, std::ostream& out) {
  const SiteModel model = load_site_model(request.store, request.site);
  const engine::Geodetic origin = geographic_origin(model);
  const Cloud cloud = request.options.cloud;
  try {
    // Dated by the model's commit: the same version, the same bytes.
    put(out, encode_site_las(load_cloud(request.store, model, cloud), origin,
                             request.options, model.updated_us));
  } catch (const std::invalid_argument& e) {
    throw util::Error(util::ErrorKind::kInvalidArgument, e.what());
  }
  return cloud_file_name(model, cloud, las);
}

}  // namespace

const Exporter las{
    "las",
    ".las",
    "application/vnd.las",
    "the point cloud as LAS 1.4 in a chosen CRS (UTM or EPSG), for GIS tools",
    true,
    true,
    &write_las};

}  // namespace formats
}  // namespace arscout::viewer
