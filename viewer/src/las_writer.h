// LAS 1.4 point clouds (ASPRS LAS 1.4 R15): point data record format 7
// (x y z as scaled 32-bit integers, 16-bit RGB, point source id, one return
// each), the CRS as an OGC WKT variable-length record, and the global
// encoding's WKT bit set, as the specification requires of formats 6-10.
// When any point has a support (fused dense points), each record carries
// 14 extra bytes, described by an Extra Bytes VLR (LASF_Spec, record 4) as
// PDAL, LAStools and CloudCompare read them: "support" (uchar, the depth
// maps that measured the point), "normal east", "normal north",
// "normal up" (float, the unit normal in the site's ENU frame) and "score"
// (uchar, the mean winning ZNCC of its depths times 255).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace arscout::viewer {

struct LasPoint {
  std::array<double, 3> xyz{};                 // in the CRS of LasFile::wkt
  std::uint16_t red = 0, green = 0, blue = 0;  // 0..65535
  std::uint16_t source_id = 0;                 // 0: unknown
  std::uint8_t support = 0;                    // 0: not a fused point
  std::array<float, 3> normal{};               // ENU, unit; zero: unknown
  std::uint8_t score = 0;  // ZNCC times 255 (ColoredPoint::score)
};

struct LasFile {
  std::string wkt;          // OGC WKT 1 of the points' CRS
  double xy_scale = 0.001;  // the stored resolution of x and y
  double z_scale = 0.001;   // and of z
  std::string software;     // "Generating Software" (32 bytes at most)
  int year = 1970;          // file creation date
  int day_of_year = 1;      // 1..366
};

// The whole file. Offsets are whole units (metres or degrees) at or below
// each axis's minimum. Throws std::invalid_argument when a coordinate is
// not finite or the cloud spans more than 32-bit integers hold at the
// scale (about 2,000 km at 1 mm).
std::string encode_las(const std::vector<LasPoint>& points,
                       const LasFile& file);

}  // namespace arscout::viewer
