#include "arscout/engine/geo.h"

#include <GeographicLib/Geocentric.hpp>
#include <GeographicLib/LocalCartesian.hpp>

namespace arscout::engine {
namespace {

GeographicLib::LocalCartesian local_frame(const Geodetic& origin) {
  return GeographicLib::LocalCartesian(origin.lat, origin.lon, origin.alt,
                                       GeographicLib::Geocentric::WGS84());
}

}  // namespace

std::array<double, 3> EnuFrame::to_enu(const Geodetic& point) const {
  std::array<double, 3> enu;
  local_frame(origin_).Forward(point.lat, point.lon, point.alt, enu[0], enu[1],
                               enu[2]);
  return enu;
}

Geodetic EnuFrame::to_geodetic(const std::array<double, 3>& enu) const {
  Geodetic g;
  local_frame(origin_).Reverse(enu[0], enu[1], enu[2], g.lat, g.lon, g.alt);
  return g;
}

std::array<double, 3> EnuFrame::to_ecef(
    const std::array<double, 3>& enu) const {
  const Geodetic g = to_geodetic(enu);
  std::array<double, 3> ecef;
  GeographicLib::Geocentric::WGS84().Forward(g.lat, g.lon, g.alt, ecef[0],
                                             ecef[1], ecef[2]);
  return ecef;
}

GeoFix geo_fix_of(const documents::GpsFix& gps) {
  GeoFix fix;
  fix.lat = gps.lat;
  fix.lon = gps.lon;
  fix.alt = gps.alt;
  if (gps.h_acc) fix.h_acc = *gps.h_acc;
  if (gps.v_acc) fix.v_acc = *gps.v_acc;
  return fix;
}

}  // namespace arscout::engine
