#include "arscout/viewer/exports.h"

#include <sstream>
#include <stdexcept>

#include "arscout/util/error.h"
#include "exporters/export_support.h"
#include "output_crs.h"

namespace arscout::viewer {

ExportFile export_site(db::Store& store, const std::string& site,
                       const Exporter& format, const ExportOptions& options) {
  std::ostringstream out(std::ios::binary);
  std::string filename = format.write({store, site, options}, out);
  return {std::move(filename), std::string(format.mime_type),
          std::move(out).str()};
}

ExportFile export_site(db::Store& store, const std::string& site,
                       std::string_view format, const ExportOptions& options) {
  const Exporter* exporter = find_exporter(format);
  if (!exporter)
    throw util::Error(util::ErrorKind::kInvalidArgument,
                      "the export format must be " + exporter_names(", ") +
                          ", not '" + std::string(format) + "'");
  return export_site(store, site, *exporter, options);
}

ExportFile export_site(db::Store& store, const std::string& site,
                       std::string_view format, Cloud cloud) {
  ExportOptions options;
  options.cloud = cloud;
  return export_site(store, site, format, options);
}

SitePoint project_site_point(db::Store& store, const std::string& site,
                             const std::array<double, 3>& enu,
                             const std::string& crs,
                             const std::string& heights) {
  const SiteModel model = load_site_model(store, site);
  const engine::Geodetic origin = formats::geographic_origin(model);
  try {
    const OutputCrs output(crs, heights, origin);
    SitePoint point;
    point.enu = enu;
    point.wgs84 =
        engine::EnuFrame(origin).to_geodetic({enu[0], enu[1], enu[2]});
    point.crs_code = output.code();
    point.crs_name = output.name();
    point.geographic = output.geographic();
    point.xyz = output.from_geodetic(point.wgs84);
    return point;
  } catch (const std::invalid_argument& e) {
    throw util::Error(util::ErrorKind::kInvalidArgument, e.what());
  }
}

}  // namespace arscout::viewer
