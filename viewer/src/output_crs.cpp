#include "output_crs.h"

#include <proj.h>

#include <cctype>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace arscout::viewer {

struct OutputCrs::Proj {
  // Quiet: errors reach the caller as exceptions, not on stderr.
  PJ_CONTEXT* context = [] {
    PJ_CONTEXT* c = proj_context_create();
    proj_log_level(c, PJ_LOG_NONE);
    return c;
  }();
  PJ* target = nullptr;     // the output CRS
  PJ* transform = nullptr;  // WGS84 3D (lon, lat, h) to it
  ~Proj() {
    if (transform) proj_destroy(transform);
    if (target) proj_destroy(target);
    proj_context_destroy(context);
  }
  std::string last_error() const {
    const char* text =
        proj_context_errno_string(context, proj_context_errno(context));
    return text ? text : "unknown PROJ error";
  }
};

namespace {

constexpr int kEgm96Height = 5773;  // EPSG: EGM96 height

bool is_epsg_code(const std::string& crs) {
  if (crs.size() < 6 || crs.size() > 11) return false;
  for (size_t i = 0; i < 5; ++i)
    if (std::toupper(static_cast<unsigned char>(crs[i])) != "EPSG:"[i])
      return false;
  for (size_t i = 5; i < crs.size(); ++i)
    if (!std::isdigit(static_cast<unsigned char>(crs[i]))) return false;
  return true;
}

std::string horizontal_code(const std::string& crs,
                            const engine::Geodetic& site) {
  if (crs == "utm") return "EPSG:" + std::to_string(utm_epsg(site));
  if (is_epsg_code(crs)) return "EPSG:" + crs.substr(5);
  throw std::invalid_argument(
      "crs must be utm (the site's UTM zone) or EPSG:<code>, not '" + crs +
      "'");
}

bool egm96_grid_present() {
  for (const char* grid : {"us_nga_egm96_15.tif", "egm96_15.gtx"})
    if (proj_grid_info(grid).filename[0] != '\0') return true;
  return false;
}

// Geographic 3D CRSs carry ellipsoidal heights of their own.
void check_kind(PJ* crs, const std::string& code, bool egm96) {
  const PJ_TYPE type = proj_get_type(crs);
  if (type == PJ_TYPE_PROJECTED_CRS || type == PJ_TYPE_GEOGRAPHIC_2D_CRS)
    return;
  if (type == PJ_TYPE_GEOGRAPHIC_3D_CRS && !egm96) return;
  if (type == PJ_TYPE_GEOGRAPHIC_3D_CRS)
    throw std::invalid_argument(
        code +
        " is geographic 3D, with ellipsoidal heights of its own; for "
        "EGM96 heights give its 2D form (EPSG:4326 for EPSG:4979)");
  if (type == PJ_TYPE_GEOCENTRIC_CRS)
    throw std::invalid_argument(
        code + " is geocentric (ECEF): export format=ecef-ply instead");
  throw std::invalid_argument(code +
                              " is not a projected or geographic 2D CRS");
}

void check_area(PJ_CONTEXT* context, PJ* crs, const std::string& code,
                const engine::Geodetic& site) {
  double west = 0, south = 0, east = 0, north = 0;
  const char* area = nullptr;
  if (!proj_get_area_of_use(context, crs, &west, &south, &east, &north,
                            &area) ||
      west <= -1000)
    return;  // PROJ knows no area: any site will do
  const bool lat_in = site.lat >= south && site.lat <= north;
  const bool lon_in = west <= east ? site.lon >= west && site.lon <= east
                                   : site.lon >= west || site.lon <= east;
  if (lat_in && lon_in) return;
  std::ostringstream why;
  why << code << " (" << proj_get_name(crs) << ") is for "
      << (area ? area : "another area") << " (latitude " << south << " to "
      << north << ", longitude " << west << " to " << east
      << "); the site is at latitude " << site.lat << ", longitude "
      << site.lon;
  throw std::invalid_argument(why.str());
}

// WGS84 3D (longitude, latitude, ellipsoidal height) to `target`, axes
// in GIS order; nullptr when PROJ has none.
PJ* wgs84_to(PJ_CONTEXT* context, PJ* target) {
  if (!target) return nullptr;
  PJ* source = proj_create(context, "EPSG:4979");
  PJ* raw = source ? proj_create_crs_to_crs_from_pj(context, source, target,
                                                    nullptr, nullptr)
                   : nullptr;
  PJ* normalized =
      raw ? proj_normalize_for_visualization(context, raw) : nullptr;
  if (raw) proj_destroy(raw);
  if (source) proj_destroy(source);
  return normalized;
}

}  // namespace

int utm_epsg(const engine::Geodetic& site) {
  if (!(site.lat >= -80 && site.lat < 84))
    throw std::invalid_argument(
        "UTM spans latitudes 80 S to 84 N and the site is at " +
        std::to_string(site.lat) +
        ": give crs=EPSG:5041 (UPS north) or EPSG:5042 (UPS south)");
  const double lon = std::remainder(site.lon, 360.0);  // [-180, 180]
  int zone = std::min(60, static_cast<int>(std::floor((lon + 180) / 6)) + 1);
  if (site.lat >= 56 && site.lat < 64 && lon >= 3 && lon < 12) zone = 32;
  if (site.lat >= 72 && lon >= 0 && lon < 42)
    zone = lon < 9 ? 31 : lon < 21 ? 33 : lon < 33 ? 35 : 37;
  return (site.lat >= 0 ? 32600 : 32700) + zone;
}

OutputCrs::OutputCrs(const std::string& crs, const std::string& heights,
                     const engine::Geodetic& site)
    : proj_(std::make_unique<Proj>()) {
  if (heights != "ellipsoid" && heights != "egm96")
    throw std::invalid_argument("heights must be ellipsoid or egm96, not '" +
                                heights + "'");
  const bool egm96 = heights == "egm96";
  const std::string horizontal = horizontal_code(crs, site);
  PJ* base = proj_create(proj_->context, horizontal.c_str());
  if (!base)
    throw std::invalid_argument(
        horizontal + " is not a CRS PROJ knows: " + proj_->last_error());
  try {
    check_kind(base, horizontal, egm96);
    check_area(proj_->context, base, horizontal, site);
  } catch (...) {
    proj_destroy(base);
    throw;
  }
  geographic_ = proj_get_type(base) != PJ_TYPE_PROJECTED_CRS;
  proj_destroy(base);
  if (egm96 && !egm96_grid_present())
    throw std::invalid_argument(
        "EGM96 heights need PROJ's EGM96 grid (egm96_15.gtx, Debian package "
        "proj-data), which is not installed");
  code_ = egm96 ? horizontal + "+" + std::to_string(kEgm96Height) : horizontal;
  proj_->target = proj_create(proj_->context, code_.c_str());
  proj_->transform = wgs84_to(proj_->context, proj_->target);
  if (!proj_->transform)
    throw std::invalid_argument("no transformation from WGS84 to " + code_ +
                                ": " + proj_->last_error());
  name_ = proj_get_name(proj_->target);
  const char* wkt =
      proj_as_wkt(proj_->context, proj_->target, PJ_WKT1_GDAL, nullptr);
  if (!wkt)
    throw std::invalid_argument(
        code_ + " has no OGC WKT 1 form: " + proj_->last_error());
  wkt_ = wkt;
  from_geodetic(site);  // fails here, not midway through a cloud
}

OutputCrs::~OutputCrs() = default;

std::array<double, 3> OutputCrs::from_geodetic(
    const engine::Geodetic& point) const {
  const PJ_COORD out = proj_trans(
      proj_->transform, PJ_FWD, proj_coord(point.lon, point.lat, point.alt, 0));
  const std::array<double, 3> xyz{out.xyz.x, out.xyz.y, out.xyz.z};
  for (double v : xyz)
    if (!std::isfinite(v))
      throw std::runtime_error("PROJ cannot take latitude " +
                               std::to_string(point.lat) + ", longitude " +
                               std::to_string(point.lon) + " to " + code_ +
                               ": " + proj_->last_error());
  return xyz;
}

}  // namespace arscout::viewer
