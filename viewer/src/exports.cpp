#include "arscout/viewer/exports.h"
#include "arscout/util/error.h"

#include <bit>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "arscout/documents/document_error.h"
#include "arscout/documents/geojson.h"
#include "arscout/engine/geo.h"
#include "arscout/engine/model_io.h"
#include "arscout/util/file.h"
#include "las_writer.h"
#include "output_crs.h"
#include "point_tileset.h"
#include "tar_writer.h"
#include "zip_writer.h"

namespace arscout::viewer {
namespace {

namespace fs = std::filesystem;

// A folder of its own under the system's temporary directory, removed with
// everything in it when the scope ends: the model writers write files.
class ScratchDir {
 public:
  ScratchDir() {
    std::random_device entropy;
    path_ = fs::temp_directory_path() /
            ("arscout-export-" + std::to_string(entropy()) + "-" +
             std::to_string(entropy()));
    fs::create_directories(path_);
  }
  ~ScratchDir() {
    std::error_code ignored;
    fs::remove_all(path_, ignored);
  }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

engine::Geodetic origin_of(const SiteModel& model) {
  const auto& origin = model.document.enu_origin;
  if (!model.document.geo_registered || !origin)
    throw util::Error(util::ErrorKind::kInvalidArgument,
                      "site " + model.site +
                          ": the model is not geo-registered yet (fewer than "
                          "three registered captures with GPS), so it has no "
                          "geographic frame to export");
  return {origin->lat, origin->lon, origin->alt};
}

ExportFile colmap_tar(db::Store& store, const std::string& site) {
  SiteModel model;
  const engine::Model full = load_consistent_full_model(store, site, &model);
  ScratchDir scratch;
  engine::write_colmap_text(full, scratch.path().string());
  // The model's commit time, so the same version always exports the same
  // bytes.
  const long long mtime = model.updated_us / 1000000;
  TarWriter tar;
  for (const char* name : {"cameras.txt", "images.txt", "points3D.txt"})
    tar.add(site + "/" + name,
            util::read_file((scratch.path() / name).string()), mtime);
  return {site + "-v" + std::to_string(model.version) + "-colmap.tar",
          "application/x-tar", tar.finish()};
}

ExportFile geo_csv(db::Store& store, const std::string& site) {
  SiteModel model;
  const engine::Model full = load_consistent_full_model(store, site, &model);
  origin_of(model);  // refuses a model without geography
  ScratchDir scratch;
  const fs::path file = scratch.path() / "cameras_geo.csv";
  engine::write_geo_csv(full, file.string());
  return {site + "-v" + std::to_string(model.version) + "-cameras.csv",
          "text/csv; charset=utf-8", util::read_file(file.string())};
}

// Dated by the model's commit: the same version, the same bytes.
std::string tileset_zip(const std::vector<engine::ColoredPoint>& cloud,
                        const engine::Geodetic& origin, const std::string& site,
                        std::int64_t updated_us) {
  if (cloud.empty())
    throw util::Error(util::ErrorKind::kNotFound,
                      "site " + site + ": the model has no point cloud");
  ZipWriter zip;
  for (const TilesetFile& file : build_point_tileset(cloud, origin))
    zip.add(site + "/" + file.path, file.bytes, updated_us / 1000000);
  return zip.finish();
}

// As HttpResponse::json writes it, so the CLI and GET .../cameras.geojson
// give the same bytes.
std::string cameras_geojson_text(const SiteModel& model) {
  try {
    return documents::cameras_geojson(model.document)
        .dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  } catch (const documents::DocumentError& e) {
    throw util::Error(util::ErrorKind::kInvalidArgument, e.what());
  }
}

}  // namespace

std::optional<ExportFormat> parse_export_format(const std::string& name) {
  if (name == "ply") return ExportFormat::kPly;
  if (name == "colmap") return ExportFormat::kColmap;
  if (name == "geocsv") return ExportFormat::kGeoCsv;
  if (name == "ecef-ply") return ExportFormat::kEcefPly;
  if (name == "las") return ExportFormat::kLas;
  if (name == "3dtiles") return ExportFormat::k3dTiles;
  if (name == "geojson") return ExportFormat::kGeoJson;
  return std::nullopt;
}

const char* to_string(ExportFormat format) {
  switch (format) {
    case ExportFormat::kPly:
      return "ply";
    case ExportFormat::kColmap:
      return "colmap";
    case ExportFormat::kGeoCsv:
      return "geocsv";
    case ExportFormat::kEcefPly:
      return "ecef-ply";
    case ExportFormat::kLas:
      return "las";
    case ExportFormat::k3dTiles:
      return "3dtiles";
    case ExportFormat::kGeoJson:
      return "geojson";
  }
  return "?";
}

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

ExportFile export_site(db::Store& store, const std::string& site,
                       ExportFormat format, Cloud cloud) {
  ExportOptions options;
  options.cloud = cloud;
  return export_site(store, site, format, options);
}

ExportFile export_site(db::Store& store, const std::string& site,
                       ExportFormat format, const ExportOptions& options) {
  const Cloud cloud = options.cloud;
  if (format == ExportFormat::kColmap) return colmap_tar(store, site);
  if (format == ExportFormat::kGeoCsv) return geo_csv(store, site);
  const SiteModel model = load_site_model(store, site);
  const std::string which = cloud_name(model, cloud);
  const std::string base =
      site + "-v" + std::to_string(model.version) + "-" + which;
  if (format == ExportFormat::kPly) {
    if (model.sparse_blob.empty())
      throw util::Error(util::ErrorKind::kNotFound,
                        "site " + site + ": the model has no point cloud");
    // The sparse cloud is one blob; the dense one is joined from its tiles.
    if (which == "sparse")
      return {base + ".ply", "application/x-ply",
              store.get_blob(model.sparse_blob)};
    return {base + ".ply", "application/x-ply",
            engine::encode_ply(load_cloud(store, model, cloud),
                               "arscout site " + site + " model v" +
                                   std::to_string(model.version) +
                                   " dense cloud; frame site")};
  }
  const engine::Geodetic origin = origin_of(model);
  if (format == ExportFormat::kGeoJson)
    return {site + "-v" + std::to_string(model.version) + "-cameras.geojson",
            "application/geo+json", cameras_geojson_text(model)};
  if (format == ExportFormat::k3dTiles)
    return {base + "-3dtiles.zip", "application/zip",
            tileset_zip(load_cloud(store, model, cloud), origin, site,
                        model.updated_us)};
  if (format == ExportFormat::kLas) {
    // Dated by the model's commit: the same version, the same bytes.
    try {
      return {base + ".las", "application/vnd.las",
              encode_site_las(load_cloud(store, model, cloud), origin, options,
                              model.updated_us)};
    } catch (const std::invalid_argument& e) {
      throw util::Error(util::ErrorKind::kInvalidArgument, e.what());
    }
  }
  const std::string comment = "arscout site " + site + " model v" +
                              std::to_string(model.version) + " " + which +
                              " cloud; frame ECEF WGS84 (EPSG:4978), metres";
  return {base + "-ecef.ply", "application/x-ply",
          encode_ecef_ply(load_cloud(store, model, cloud), origin, comment)};
}

SitePoint project_site_point(db::Store& store, const std::string& site,
                             const std::array<double, 3>& enu,
                             const std::string& crs,
                             const std::string& heights) {
  const SiteModel model = load_site_model(store, site);
  const engine::Geodetic origin = origin_of(model);
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
