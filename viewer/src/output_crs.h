// The coordinate reference system of a geographic export (docs/frames.md):
// the site's own UTM zone or any projected or geographic CRS with an EPSG
// code, with ellipsoidal or EGM96 heights. The site's ENU frame stays the
// engine's; projection happens here, on export only. PROJ is confined to
// output_crs.cpp.
#pragma once

#include <array>
#include <memory>
#include <string>

#include "arscout/engine/geo.h"

namespace arscout::viewer {

class OutputCrs {
 public:
  // `crs`: "utm" (WGS 84 / UTM, the zone and hemisphere of `site`, with
  // the Norway and Svalbard exceptions) or "EPSG:N" for a projected or
  // geographic 2D CRS of PROJ's database whose area of use holds `site`.
  // `heights`: "ellipsoid" (WGS84 ellipsoidal) or "egm96" (orthometric,
  // EGM96 geoid; the CRS becomes a compound with EPSG:5773).
  // Throws std::invalid_argument saying what is wrong: an unknown code, a
  // geocentric, vertical or other kind of CRS, a site outside the CRS's
  // area of use or beyond UTM's latitudes, another heights name, or EGM96
  // heights without PROJ's EGM96 grid (Debian proj-data).
  OutputCrs(const std::string& crs, const std::string& heights,
            const engine::Geodetic& site);
  ~OutputCrs();
  OutputCrs(const OutputCrs&) = delete;
  OutputCrs& operator=(const OutputCrs&) = delete;

  // A WGS84 point (degrees, ellipsoidal metres) in this CRS: easting and
  // northing in metres for a projected CRS, longitude and latitude in
  // degrees for a geographic one (GIS order), then the height. Throws
  // std::runtime_error when PROJ cannot transform it.
  std::array<double, 3> from_geodetic(const engine::Geodetic& point) const;

  bool geographic() const { return geographic_; }
  // "EPSG:32632", or "EPSG:32632+5773" with EGM96 heights.
  const std::string& code() const { return code_; }
  // PROJ's name, e.g. "WGS 84 / UTM zone 32N + EGM96 height".
  const std::string& name() const { return name_; }
  // OGC WKT 1 (GDAL's dialect, what LAS 1.4 and most GIS tools read).
  const std::string& wkt() const { return wkt_; }

 private:
  struct Proj;
  std::unique_ptr<Proj> proj_;
  bool geographic_ = false;
  std::string code_, name_, wkt_;
};

// The EPSG code of WGS 84 / UTM for `site` (326zz north, 327zz south).
// Throws std::invalid_argument beyond UTM's latitudes (80 S to 84 N).
int utm_epsg(const engine::Geodetic& site);

}  // namespace arscout::viewer
