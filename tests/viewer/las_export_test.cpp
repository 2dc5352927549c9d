// The LAS export and its output CRSs on a synthetic cloud with exact
// answers: the file is read back here byte by byte (not with the writer's
// code), its points are checked against an independent route (GeographicLib's
// LocalCartesian and UTM), its WKT against GDAL's gdalsrsinfo, and EGM96
// heights against PROJ's cs2cs.
#include <array>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <GeographicLib/LocalCartesian.hpp>
#include <GeographicLib/UTMUPS.hpp>

#include "arscout/viewer/exports.h"
#include "bytes_at.h"
#include "output_crs.h"
#include "test_stores.h"
#include "tool_process.h"

namespace arscout::viewer {
namespace {

namespace fs = std::filesystem;

const engine::Geodetic kGraz{47.0707, 15.4395, 353.5};
constexpr std::int64_t kCreatedUs = 1764115200000000;  // 2025-11-26

using testing_bytes::read_at;

struct ParsedLas {
  std::uint8_t major = 0, minor = 0, format = 0;
  std::uint16_t encoding = 0, header_size = 0, record_length = 0;
  std::uint32_t vlrs = 0, point_offset = 0, legacy_count = 0;
  std::uint64_t count = 0;
  std::array<double, 3> scale{}, offset{}, max{}, min{};
  std::string vlr_user, wkt;
  std::uint16_t vlr_record = 0;
  std::vector<std::array<double, 3>> xyz;
  std::vector<std::array<std::uint16_t, 3>> rgb;
};

// The header fields at their LAS 1.4 offsets, the one VLR, the points.
ParsedLas parse_las(const std::string& b) {
  ParsedLas las;
  EXPECT_EQ(b.substr(0, 4), "LASF");
  las.encoding = read_at<std::uint16_t>(b, 6);
  las.major = read_at<std::uint8_t>(b, 24);
  las.minor = read_at<std::uint8_t>(b, 25);
  las.header_size = read_at<std::uint16_t>(b, 94);
  las.point_offset = read_at<std::uint32_t>(b, 96);
  las.vlrs = read_at<std::uint32_t>(b, 100);
  las.format = read_at<std::uint8_t>(b, 104);
  las.record_length = read_at<std::uint16_t>(b, 105);
  las.legacy_count = read_at<std::uint32_t>(b, 107);
  for (int a = 0; a < 3; ++a) {
    las.scale[a] = read_at<double>(b, 131 + 8 * a);
    las.offset[a] = read_at<double>(b, 155 + 8 * a);
    las.max[a] = read_at<double>(b, 179 + 16 * a);
    las.min[a] = read_at<double>(b, 187 + 16 * a);
  }
  las.count = read_at<std::uint64_t>(b, 247);
  las.vlr_user = std::string(b.data() + 375 + 2);
  las.vlr_record = read_at<std::uint16_t>(b, 375 + 18);
  const std::uint16_t length = read_at<std::uint16_t>(b, 375 + 20);
  las.wkt = std::string(b.data() + 375 + 54, length);
  las.wkt.resize(las.wkt.find('\0'));
  for (std::uint64_t i = 0; i < las.count; ++i) {
    const size_t at = las.point_offset + i * las.record_length;
    std::array<double, 3> p{};
    for (int a = 0; a < 3; ++a)
      p[a] =
          read_at<std::int32_t>(b, at + 4 * a) * las.scale[a] + las.offset[a];
    las.xyz.push_back(p);
    las.rgb.push_back({read_at<std::uint16_t>(b, at + 30),
                       read_at<std::uint16_t>(b, at + 32),
                       read_at<std::uint16_t>(b, at + 34)});
  }
  return las;
}

// 2000 points within 400 m of the origin, 40 m up and down.
std::vector<engine::ColoredPoint> street_cloud() {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> across(-400, 400), up(-40, 40);
  std::uniform_int_distribution<int> colour(0, 255);
  std::vector<engine::ColoredPoint> cloud;
  for (int i = 0; i < 2000; ++i)
    cloud.push_back({across(rng), across(rng), up(rng),
                     static_cast<std::uint8_t>(colour(rng)),
                     static_cast<std::uint8_t>(colour(rng)),
                     static_cast<std::uint8_t>(colour(rng))});
  return cloud;
}

ExportOptions las_options(const std::string& crs, const std::string& heights) {
  ExportOptions options;
  options.crs = crs;
  options.heights = heights;
  return options;
}

// Fused points (a support) carry their support, ENU normal and score in 14
// extra bytes, described by an Extra Bytes VLR after the WKT.
TEST(LasExport, FusedPointsCarrySupportNormalAndScoreInExtraBytes) {
  auto cloud = street_cloud();
  for (size_t i = 0; i < cloud.size(); ++i) {
    cloud[i].support = static_cast<std::uint8_t>(1 + i % 9);
    cloud[i].nx = 0.6f, cloud[i].ny = 0, cloud[i].nz = i % 2 ? 0.8f : -0.8f;
    cloud[i].score = static_cast<std::uint8_t>(100 + i % 150);
  }
  const std::string b = encode_site_las(
      cloud, kGraz, las_options("utm", "ellipsoid"), kCreatedUs);
  const ParsedLas las = parse_las(b);
  EXPECT_EQ(las.vlrs, 2u);
  EXPECT_EQ(las.record_length, 36 + 14);
  // The second VLR: LASF_Spec record 4, five 192-byte descriptors.
  const size_t vlr = 375 + 54 + read_at<std::uint16_t>(b, 375 + 20);
  EXPECT_EQ(std::string(b.data() + vlr + 2), "LASF_Spec");
  EXPECT_EQ(read_at<std::uint16_t>(b, vlr + 18), 4);
  ASSERT_EQ(read_at<std::uint16_t>(b, vlr + 20), 5 * 192);
  EXPECT_EQ(las.point_offset, vlr + 54 + 5 * 192);
  const char* names[] = {"support", "normal east", "normal north", "normal up",
                         "score"};
  const std::uint8_t types[] = {1, 9, 9, 9, 1};  // unsigned char, float
  for (int d = 0; d < 5; ++d) {
    const size_t at = vlr + 54 + 192 * d;
    EXPECT_EQ(read_at<std::uint8_t>(b, at + 2), types[d]) << d;
    EXPECT_EQ(read_at<std::uint8_t>(b, at + 3), 0) << d;  // options
    EXPECT_EQ(std::string(b.data() + at + 4), names[d]) << d;
  }
  ASSERT_EQ(las.count, cloud.size());
  EXPECT_EQ(b.size(), las.point_offset + cloud.size() * (36 + 14));
  for (size_t i = 0; i < cloud.size(); ++i) {
    const size_t at = las.point_offset + i * las.record_length + 36;
    EXPECT_EQ(read_at<std::uint8_t>(b, at), cloud[i].support) << i;
    EXPECT_EQ(read_at<float>(b, at + 1), 0.6f) << i;
    EXPECT_EQ(read_at<float>(b, at + 9), cloud[i].nz) << i;
    EXPECT_EQ(read_at<std::uint8_t>(b, at + 13), cloud[i].score) << i;
  }
  // The coordinates read as before.
  const ParsedLas plain = parse_las(encode_site_las(
      street_cloud(), kGraz, las_options("utm", "ellipsoid"), kCreatedUs));
  EXPECT_EQ(plain.xyz, las.xyz);
}

TEST(LasExport, HeaderAndPointsReadBackIndependently) {
  const auto cloud = street_cloud();
  const ParsedLas las = parse_las(encode_site_las(
      cloud, kGraz, las_options("utm", "ellipsoid"), kCreatedUs));
  EXPECT_EQ(las.major, 1);
  EXPECT_EQ(las.minor, 4);
  EXPECT_EQ(las.encoding & 0x10, 0x10);  // WKT
  EXPECT_EQ(las.header_size, 375);
  EXPECT_EQ(las.format, 7);
  EXPECT_EQ(las.record_length, 36);
  EXPECT_EQ(las.legacy_count, 0u);
  EXPECT_EQ(las.vlrs, 1u);
  EXPECT_EQ(las.vlr_user, "LASF_Projection");
  EXPECT_EQ(las.vlr_record, 2112);
  ASSERT_EQ(las.count, cloud.size());
  for (int a = 0; a < 3; ++a) {
    EXPECT_EQ(las.scale[a], 0.001);
    double lo = 1e300, hi = -1e300;
    for (const auto& p : las.xyz) {
      lo = std::min(lo, p[a]);
      hi = std::max(hi, p[a]);
    }
    EXPECT_NEAR(las.min[a], lo, 1e-9);
    EXPECT_NEAR(las.max[a], hi, 1e-9);
  }
  for (size_t i = 0; i < cloud.size(); ++i) {
    EXPECT_EQ(las.rgb[i][0], cloud[i].r * 257) << i;
    EXPECT_EQ(las.rgb[i][2], cloud[i].b * 257) << i;
  }
  EXPECT_NE(las.wkt.find("UTM zone 33N"), std::string::npos) << las.wkt;
  EXPECT_NE(las.wkt.find("32633"), std::string::npos);
}

// ENU -> WGS84 -> UTM by GeographicLib, not PROJ: to a millimetre.
TEST(LasExport, PointsMatchGeographicLibUtmToAMillimetre) {
  const auto cloud = street_cloud();
  const ParsedLas las = parse_las(encode_site_las(
      cloud, kGraz, las_options("utm", "ellipsoid"), kCreatedUs));
  ASSERT_EQ(las.count, cloud.size());
  const GeographicLib::LocalCartesian enu(kGraz.lat, kGraz.lon, kGraz.alt);
  double worst = 0;
  for (size_t i = 0; i < cloud.size(); i += cloud.size() / 100) {
    double lat, lon, h, x, y, gamma, k;
    enu.Reverse(cloud[i].x, cloud[i].y, cloud[i].z, lat, lon, h);
    int zone;
    bool north;
    GeographicLib::UTMUPS::Forward(lat, lon, zone, north, x, y, gamma, k, 33);
    worst =
        std::max({worst, std::abs(las.xyz[i][0] - x),
                  std::abs(las.xyz[i][1] - y), std::abs(las.xyz[i][2] - h)});
  }
  std::cout << "LAS vs GeographicLib UTM, 100 points: worst " << worst * 1000
            << " mm" << std::endl;
  EXPECT_LE(worst, 0.001);
}

TEST(LasExport, GeographicCrsStoresDegreesToAMillimetre) {
  const auto cloud = street_cloud();
  const ParsedLas las = parse_las(encode_site_las(
      cloud, kGraz, las_options("EPSG:4326", "ellipsoid"), kCreatedUs));
  EXPECT_EQ(las.scale[0], 1e-8);
  EXPECT_EQ(las.scale[2], 0.001);
  const GeographicLib::LocalCartesian enu(kGraz.lat, kGraz.lon, kGraz.alt);
  for (size_t i = 0; i < cloud.size(); i += cloud.size() / 100) {
    double lat, lon, h;
    enu.Reverse(cloud[i].x, cloud[i].y, cloud[i].z, lat, lon, h);
    EXPECT_NEAR(las.xyz[i][0], lon, 1e-8) << i;  // GIS order: x is longitude
    EXPECT_NEAR(las.xyz[i][1], lat, 1e-8) << i;
    EXPECT_NEAR(las.xyz[i][2], h, 1e-3) << i;
  }
}

bool have_tool(const char* name) {
  return std::system(
             (std::string("command -v ") + name + " >/dev/null").c_str()) == 0;
}

#define TOOL_OR_SKIP(name)                                                     \
  do {                                                                         \
    if (!have_tool(name)) {                                                    \
      if (testing::in_ci())                                                    \
        FAIL() << name << " missing (deploy/install-deps.sh)";                 \
      GTEST_SKIP() << name << " missing (deploy/install-deps.sh installs it)"; \
    }                                                                          \
  } while (0)

TEST(LasExport, GdalReadsTheWkt) {
  TOOL_OR_SKIP("gdalsrsinfo");
  const fs::path dir = testing::make_temp_dir("las-wkt");
  for (const char* crs : {"utm", "EPSG:31256"}) {
    for (const char* heights : {"ellipsoid", "egm96"}) {
      const OutputCrs out(crs, heights, kGraz);
      std::ofstream(dir / "crs.wkt") << out.wkt();
      const std::string file = "'" + (dir / "crs.wkt").string() + "'";
      // Parsed (a non-empty answer needs exit status 0), with the
      // horizontal CRS's EPSG code and the vertical datum kept.
      const std::string horizontal =
          out.code().substr(5, out.code().find('+') - 5);
      const std::string wkt1 =
          testing::command_output("gdalsrsinfo -o wkt1 " + file);
      EXPECT_NE(wkt1.find("AUTHORITY[\"EPSG\",\"" + horizontal + "\"]"),
                std::string::npos)
          << crs << " " << heights << ": gdalsrsinfo said '" << wkt1 << "'";
      EXPECT_EQ(wkt1.find("EGM96") != std::string::npos,
                std::string(heights) == "egm96")
          << wkt1;
      // GDAL identifies a horizontal CRS's code; a compound has none.
      if (std::string(heights) == "ellipsoid") {
        EXPECT_NE(testing::command_output("gdalsrsinfo -o epsg " + file)
                      .find("EPSG:" + horizontal),
                  std::string::npos);
      }
    }
  }
}

// PROJ's own command-line tool gives the geoid undulation independently.
TEST(LasExport, Egm96HeightsAreTheGeoidUndulationBelowTheEllipsoid) {
  TOOL_OR_SKIP("cs2cs");
  const auto cloud = street_cloud();
  const ParsedLas ellipsoid = parse_las(encode_site_las(
      cloud, kGraz, las_options("utm", "ellipsoid"), kCreatedUs));
  const ParsedLas egm96 = parse_las(
      encode_site_las(cloud, kGraz, las_options("utm", "egm96"), kCreatedUs));
  EXPECT_NE(egm96.wkt.find("EGM96"), std::string::npos);
  const std::string out = testing::command_output(
      "echo '" + std::to_string(kGraz.lat) + " " + std::to_string(kGraz.lon) +
      " 0' | cs2cs -f %.4f EPSG:4979 EPSG:4326+5773");
  double lat = 0, lon = 0, height = 0;
  ASSERT_EQ(std::sscanf(out.c_str(), "%lf %lf %lf", &lat, &lon, &height), 3)
      << out;
  const double undulation = -height;
  std::cout << "EGM96 undulation at Graz by cs2cs: " << undulation << " m"
            << std::endl;
  for (size_t i = 0; i < cloud.size(); i += 20)
    EXPECT_NEAR(ellipsoid.xyz[i][2] - egm96.xyz[i][2], undulation, 0.05) << i;
}

TEST(OutputCrs, RefusesWhatDoesNotFitTheSite) {
  EXPECT_THROW(OutputCrs("EPSG:2056", "ellipsoid", kGraz),  // Switzerland
               std::invalid_argument);
  EXPECT_THROW(OutputCrs("EPSG:4978", "ellipsoid", kGraz),  // geocentric
               std::invalid_argument);
  EXPECT_THROW(OutputCrs("EPSG:999999", "ellipsoid", kGraz),
               std::invalid_argument);
  EXPECT_THROW(OutputCrs("UTM33", "ellipsoid", kGraz), std::invalid_argument);
  EXPECT_THROW(OutputCrs("utm", "geoid", kGraz), std::invalid_argument);
  EXPECT_THROW(OutputCrs("EPSG:4979", "egm96", kGraz), std::invalid_argument);
  try {
    OutputCrs("EPSG:2056", "ellipsoid", kGraz);
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("the site is at"), std::string::npos)
        << e.what();
  }
  EXPECT_EQ(OutputCrs("epsg:3857", "ellipsoid", kGraz).code(), "EPSG:3857");
}

TEST(OutputCrs, UtmZonesWithTheirExceptions) {
  EXPECT_EQ(utm_epsg({47.07, 15.44, 0}), 32633);
  EXPECT_EQ(utm_epsg({-33.9, 18.4, 0}), 32734);
  EXPECT_EQ(utm_epsg({60.0, 5.0, 0}), 32632);   // south-west Norway
  EXPECT_EQ(utm_epsg({78.0, 15.0, 0}), 32633);  // Svalbard
  EXPECT_EQ(utm_epsg({10.0, 179.9, 0}), 32660);
  EXPECT_EQ(utm_epsg({10.0, -180.0, 0}), 32601);
  EXPECT_THROW(utm_epsg({85.0, 0, 0}), std::invalid_argument);
  for (const auto& site :
       {engine::Geodetic{60.0, 5.0, 0}, engine::Geodetic{-33.9, 18.4, 0}}) {
    int zone;
    bool north;
    double x, y, gamma, k;
    GeographicLib::UTMUPS::Forward(site.lat, site.lon, zone, north, x, y, gamma,
                                   k);
    EXPECT_EQ(utm_epsg(site), (north ? 32600 : 32700) + zone);
  }
}

}  // namespace
}  // namespace arscout::viewer
