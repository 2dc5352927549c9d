// GPS and EXIF readers: the Strecha gps.csv and the OpenSfM photos (real
// EXIF GPS), GPX tracks and broken inputs written here, and a JPEG whose EXIF
// is assembled byte by byte so every tag's decoding can be checked exactly.
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "arscout/metadata/gps.h"
#include "test_stores.h"

namespace arscout::metadata {
namespace {

namespace fs = std::filesystem;

std::string write_temp(const std::string& name, const std::string& content) {
  static const std::string dir = testing::make_temp_dir("gps-readers");
  std::string path = dir + "/" + name;
  std::ofstream(path, std::ios::binary) << content;
  return path;
}

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// The message of the std::runtime_error that f throws ("" if none).
template <class F>
std::string error_of(F f) {
  try {
    f();
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

// Great-circle distance in metres, enough to compare positions.
double distance_m(double lat1, double lon1, double lat2, double lon2) {
  constexpr double kRad = M_PI / 180, kEarth = 6371000;
  double x = (lon2 - lon1) * kRad * std::cos((lat1 + lat2) / 2 * kRad);
  double y = (lat2 - lat1) * kRad;
  return std::hypot(x, y) * kEarth;
}

// ---- EXIF assembled by hand
// ---------------------------------------------------

enum TiffType : std::uint16_t {
  kByte = 1,
  kAscii = 2,
  kShort = 3,
  kLong = 4,
  kRational = 5
};

struct TiffEntry {
  std::uint16_t tag;
  TiffType type;
  std::uint32_t count;
  std::string data;  // little-endian value bytes
};

std::string le(std::uint32_t v, int bytes) {
  std::string s;
  for (int i = 0; i < bytes; ++i) s += static_cast<char>((v >> (8 * i)) & 0xff);
  return s;
}

TiffEntry ascii(std::uint16_t tag, const std::string& text) {
  return {tag, kAscii, static_cast<std::uint32_t>(text.size() + 1),
          text + '\0'};
}

TiffEntry rationals(std::uint16_t tag,
                    std::vector<std::pair<std::uint32_t, std::uint32_t>> v) {
  std::string data;
  for (auto [num, den] : v) data += le(num, 4) + le(den, 4);
  return {tag, kRational, static_cast<std::uint32_t>(v.size()), data};
}

TiffEntry short_value(std::uint16_t tag, std::uint16_t v) {
  return {tag, kShort, 1, le(v, 2)};
}

TiffEntry long_value(std::uint16_t tag, std::uint32_t v) {
  return {tag, kLong, 1, le(v, 4)};
}

// Appends an IFD (values over 4 bytes after it) to tiff; returns the offsets
// of each entry's value field, to patch pointers to IFDs written later.
std::vector<std::size_t> append_ifd(std::string& tiff,
                                    const std::vector<TiffEntry>& entries) {
  std::size_t data_at = tiff.size() + 2 + 12 * entries.size() + 4;
  std::string data;
  std::vector<std::size_t> value_offsets;
  tiff += le(static_cast<std::uint32_t>(entries.size()), 2);
  for (const auto& e : entries) {
    tiff += le(e.tag, 2) + le(e.type, 2) + le(e.count, 4);
    value_offsets.push_back(tiff.size());
    if (e.data.size() <= 4) {
      tiff += e.data + std::string(4 - e.data.size(), '\0');
    } else {
      tiff += le(static_cast<std::uint32_t>(data_at + data.size()), 4);
      data += e.data + std::string(e.data.size() % 2, '\0');
    }
  }
  tiff += le(0, 4) + data;  // no next IFD
  return value_offsets;
}

void patch(std::string& tiff, std::size_t at, std::uint32_t value) {
  tiff.replace(at, 4, le(value, 4));
}

// A small real JPEG carrying IFD0 (with pointers to the Exif and GPS IFDs).
std::string jpeg_with_exif(std::vector<TiffEntry> ifd0,
                           const std::vector<TiffEntry>& exif,
                           const std::vector<TiffEntry>& gps) {
  ifd0.push_back(long_value(0x8769, 0));  // ExifIFD pointer
  ifd0.push_back(long_value(0x8825, 0));  // GPS IFD pointer
  std::string tiff = std::string("II*\0", 4) + le(8, 4);
  auto pointers = append_ifd(tiff, ifd0);
  patch(tiff, pointers[pointers.size() - 2],
        static_cast<std::uint32_t>(tiff.size()));
  append_ifd(tiff, exif);
  patch(tiff, pointers.back(), static_cast<std::uint32_t>(tiff.size()));
  append_ifd(tiff, gps);

  std::vector<uchar> jpeg;
  cv::imencode(".jpg", cv::Mat(48, 64, CV_8UC3, cv::Scalar(40, 120, 200)),
               jpeg);
  std::string app1 = "\xFF\xE1";
  std::string payload = std::string("Exif\0\0", 6) + tiff;
  app1 += static_cast<char>((payload.size() + 2) >> 8);
  app1 += static_cast<char>((payload.size() + 2) & 0xff);
  std::string bytes(jpeg.begin(), jpeg.end());
  return bytes.insert(2, app1 + payload);  // right after SOI
}

std::vector<TiffEntry> full_exif_ifd() {
  return {ascii(0x9003, "2024:03:05 15:07:30"),  // DateTimeOriginal
          rationals(0x920A, {{42, 10}}),         // FocalLength
          long_value(0xA002, 64),                // PixelXDimension
          long_value(0xA003, 48),                // PixelYDimension
          rationals(0xA20E, {{5000, 1}}),        // FocalPlaneXResolution
          short_value(0xA210, 3),                // ... its unit: cm
          short_value(0xA405, 28)};              // 35 mm equivalent
}

std::vector<TiffEntry> southern_western_gps() {
  return {ascii(0x0001, "S"),
          rationals(0x0002, {{33, 1}, {27, 1}, {0, 1}}),
          ascii(0x0003, "W"),
          rationals(0x0004, {{70, 1}, {40, 1}, {1230, 100}}),
          {0x0005, kByte, 1, std::string(1, '\1')},  // below sea level
          rationals(0x0006, {{125, 10}}),
          rationals(0x0007, {{14, 1}, {7, 1}, {305, 10}}),
          ascii(0x0008, "07"),
          rationals(0x000B, {{2, 1}}),  // DOP, overridden by the next
          ascii(0x001D, "2024:03:05"),
          rationals(0x001F, {{35, 10}})};  // GPSHPositioningError
}

TEST(ExifSynthetic, DecodesEveryTag) {
  auto info = read_exif(
      jpeg_with_exif({ascii(0x010F, "TestCam"), ascii(0x0110, "TC-1  ")},
                     full_exif_ifd(), southern_western_gps()));
  ASSERT_TRUE(info.gps);
  EXPECT_NEAR(info.gps->lat, -33.45, 1e-9);
  EXPECT_NEAR(info.gps->lon, -(70 + 40 / 60.0 + 12.3 / 3600), 1e-9);
  EXPECT_DOUBLE_EQ(info.gps->alt.value(), -12.5);
  EXPECT_DOUBLE_EQ(info.gps->h_acc.value(), 3.5);
  EXPECT_FALSE(info.gps->v_acc);
  EXPECT_EQ(info.gps->satellites.value(), 7);
  EXPECT_EQ(info.gps->time, "2024-03-05T14:07:30Z");
  EXPECT_EQ(info.gps->source, "exif");
  EXPECT_EQ(info.taken, "2024-03-05T15:07:30");
  EXPECT_DOUBLE_EQ(info.focal_mm.value(), 4.2);
  EXPECT_DOUBLE_EQ(info.focal_35mm.value(), 28);
  EXPECT_DOUBLE_EQ(info.focal_plane_x_res.value(), 5000);
  EXPECT_DOUBLE_EQ(info.focal_plane_unit_mm.value(), 10);
  EXPECT_EQ(info.make, "TestCam");
  EXPECT_EQ(info.model, "TC-1");
  EXPECT_EQ(info.width, 64);
  EXPECT_EQ(info.height, 48);
}

TEST(ExifSynthetic, AccuracyFromDopWhenNoPositioningError) {
  auto info = read_exif(jpeg_with_exif(
      {}, {},
      {ascii(0x0001, "N"), rationals(0x0002, {{10, 1}, {30, 1}, {0, 1}}),
       ascii(0x0003, "E"), rationals(0x0004, {{20, 1}, {15, 1}, {0, 1}}),
       ascii(0x0008, "3 6 12 15 22"), rationals(0x000B, {{16, 10}})}));
  ASSERT_TRUE(info.gps);
  EXPECT_DOUBLE_EQ(info.gps->lat, 10.5);
  EXPECT_DOUBLE_EQ(info.gps->lon, 20.25);
  EXPECT_DOUBLE_EQ(info.gps->h_acc.value(), 8.0);  // 5 m * DOP 1.6
  EXPECT_EQ(info.gps->satellites.value(), 5);      // a list of satellite ids
  EXPECT_FALSE(info.gps->alt);
  EXPECT_TRUE(info.gps->time.empty());
  EXPECT_TRUE(info.taken.empty());
  EXPECT_EQ(info.width, 0);
}

TEST(ExifSynthetic, NoFixIsNoGps) {
  auto zeros = jpeg_with_exif(
      {}, {},
      {ascii(0x0001, "N"), rationals(0x0002, {{0, 1}, {0, 1}, {0, 1}}),
       ascii(0x0003, "E"), rationals(0x0004, {{0, 1}, {0, 1}, {0, 1}})});
  EXPECT_FALSE(read_exif(zeros).gps);
  auto void_status = jpeg_with_exif(
      {}, {},
      {ascii(0x0001, "N"), rationals(0x0002, {{10, 1}, {0, 1}, {0, 1}}),
       ascii(0x0003, "E"), rationals(0x0004, {{20, 1}, {0, 1}, {0, 1}}),
       ascii(0x0009, "V")});
  EXPECT_FALSE(read_exif(void_status).gps);
}

TEST(ExifSynthetic, BrokenValuesLeaveFieldsEmpty) {
  auto info = read_exif(jpeg_with_exif(
      {}, {ascii(0x9003, "0000:00:00 00:00:00"), rationals(0x920A, {{4, 0}})},
      {ascii(0x0001, "N"), rationals(0x0002, {{95, 1}, {0, 1}, {0, 1}}),
       ascii(0x0003, "E"), rationals(0x0004, {{20, 1}, {0, 0}, {0, 1}})}));
  EXPECT_FALSE(info.gps);  // latitude 95, and a zero denominator
  EXPECT_TRUE(info.taken.empty());
  EXPECT_FALSE(info.focal_mm);
}

// Found by tests/fuzz (fuzz_exif_gps): a 31st of February passed the
// field-by-field checks and came out as a time that is none.
TEST(ExifSynthetic, ImpossibleDatesAreNoTime) {
  auto info = read_exif(jpeg_with_exif(
      {}, {ascii(0x9003, "2025:02:31 12:00:00")},
      {ascii(0x0001, "N"), rationals(0x0002, {{10, 1}, {0, 1}, {0, 1}}),
       ascii(0x0003, "E"), rationals(0x0004, {{20, 1}, {0, 1}, {0, 1}}),
       rationals(0x0007, {{14, 1}, {7, 1}, {30, 1}}),
       ascii(0x001D, "2025:02:31")}));
  ASSERT_TRUE(info.gps);
  EXPECT_TRUE(info.gps->time.empty());
  EXPECT_TRUE(info.taken.empty());
}

TEST(ExifGarbage, ReturnsEmptyInfo) {
  for (std::string bytes :
       {std::string(), std::string("definitely not an image"),
        std::string("\xFF\xD8\xFF\xE1\x00\x20"
                    "Exif\0\0II*\0\xFF\xFF\xFF\x7F"
                    "garbagegarbagegarbage",
                    41),
        std::string(4096, '\xFF')}) {
    auto info = read_exif(bytes);
    EXPECT_FALSE(info.gps);
    EXPECT_TRUE(info.taken.empty());
    EXPECT_FALSE(info.focal_mm);
    EXPECT_EQ(info.width, 0);
  }
  EXPECT_FALSE(read_exif_file("/nonexistent/photo.jpg").gps);
}

TEST(ExifGarbage, TruncatedExifKeepsNoPartialGarbage) {
  auto jpeg = jpeg_with_exif({}, full_exif_ifd(), southern_western_gps());
  for (std::size_t cut : {std::size_t{10}, std::size_t{40}, std::size_t{120}}) {
    auto info = read_exif(std::string_view(jpeg).substr(0, cut));
    if (info.gps) {
      EXPECT_TRUE(validate_gps(*info.gps).empty());
    }
  }
}

// ---- EXIF of real photos
// --------------------------------------------------------

TEST(ExifReal, LundStreetWalk) {
  std::string dir;
  ARSCOUT_SHARED_DATA_OR_SKIP(dir, "opensfm/lund");
  auto first = read_exif_file(dir + "/images/01.jpg");
  ASSERT_TRUE(first.gps);
  EXPECT_NEAR(first.gps->lat, 55 + 41 / 60.0 + 53.4 / 3600, 1e-9);
  EXPECT_NEAR(first.gps->lon, 13 + 11 / 60.0 + 43.4 / 3600, 1e-9);
  EXPECT_DOUBLE_EQ(first.gps->alt.value(), 37);
  EXPECT_DOUBLE_EQ(first.gps->h_acc.value(), 50);  // GPSDOP 10
  EXPECT_DOUBLE_EQ(first.focal_mm.value(), 4.3);
  EXPECT_DOUBLE_EQ(first.focal_35mm.value(), 35);
  EXPECT_EQ(first.width, 1024);
  EXPECT_EQ(first.height, 768);

  int photos = 0;
  for (const auto& entry : fs::directory_iterator(dir + "/images")) {
    auto info = read_exif(slurp(entry.path().string()));
    ASSERT_TRUE(info.gps) << entry.path();
    // The whole walk is about 170 m long.
    EXPECT_LT(distance_m(info.gps->lat, info.gps->lon, first.gps->lat,
                         first.gps->lon),
              300)
        << entry.path();
    ++photos;
  }
  EXPECT_EQ(photos, 29);
}

TEST(ExifReal, BerlinDom) {
  std::string dir;
  ARSCOUT_SHARED_DATA_OR_SKIP(dir, "opensfm/berlin");
  for (const char* name : {"01.jpg", "02.jpg", "03.jpg"}) {
    auto from_file = read_exif_file(dir + "/images/" + name);
    auto from_bytes = read_exif(slurp(dir + "/images/" + name));
    ASSERT_TRUE(from_file.gps) << name;
    ASSERT_TRUE(from_bytes.gps) << name;
    EXPECT_EQ(to_json(*from_file.gps), to_json(*from_bytes.gps));
    EXPECT_LT(
        distance_m(from_file.gps->lat, from_file.gps->lon, 52.519, 13.401), 150)
        << name;
    EXPECT_EQ(from_file.width, 3264);
    EXPECT_EQ(from_file.height, 2448);
  }
}

TEST(ExifReal, StrechaPhotosHaveNoGps) {
  std::string dir;
  ARSCOUT_SHARED_DATA_OR_SKIP(dir, "strecha/fountain-P11");
  EXPECT_FALSE(read_exif_file(dir + "/images/0000.jpg").gps);
}

// ---- CSV
// -----------------------------------------------------------------------

TEST(CsvGps, ReadsStrechaFountain) {
  std::string dir;
  ARSCOUT_SHARED_DATA_OR_SKIP(dir, "strecha/fountain-P11");
  auto fixes = read_gps_csv(dir + "/gps.csv");
  ASSERT_EQ(fixes.size(), 11u);
  const GpsFix& f = fixes.at("0000.jpg");
  EXPECT_DOUBLE_EQ(f.lat, 46.519131369);
  EXPECT_DOUBLE_EQ(f.lon, 6.566644537);
  EXPECT_DOUBLE_EQ(f.alt.value(), 402.781);
  EXPECT_DOUBLE_EQ(f.h_acc.value(), 2.12);
  EXPECT_DOUBLE_EQ(f.v_acc.value(), 3.0);
  EXPECT_EQ(f.source, "csv");
  EXPECT_TRUE(fixes.count("0010.jpg"));
}

TEST(CsvGps, ColumnsByNameOptionalCellsCrlfAndBom) {
  auto path = write_temp("named.csv",
                         "\xEF\xBB\xBFlongitude,image,latitude,satellites\r\n"
                         "\r\n"
                         "# a comment\r\n"
                         "15.44,IMG_0001.jpg,47.07,9\r\n"
                         "-0.5,IMG 0002.JPG,-1.25,\r\n");
  auto fixes = read_gps_csv(path);
  ASSERT_EQ(fixes.size(), 2u);
  EXPECT_DOUBLE_EQ(fixes.at("IMG_0001.jpg").lat, 47.07);
  EXPECT_DOUBLE_EQ(fixes.at("IMG_0001.jpg").lon, 15.44);
  EXPECT_EQ(fixes.at("IMG_0001.jpg").satellites.value(), 9);
  EXPECT_FALSE(fixes.at("IMG 0002.JPG").satellites);
  EXPECT_FALSE(fixes.at("IMG 0002.JPG").alt);
}

TEST(CsvGps, ErrorsNameTheLine) {
  const std::string header =
      "image,latitude,longitude,altitude,horizontal_accuracy_m,"
      "vertical_accuracy_m\n";
  struct Case {
    std::string content;
    std::string expected;  // part of the message
  };
  for (const auto& c : std::vector<Case>{
           {"a.jpg,1,2,3,4,5\n", "line 1: expected a header"},
           {header + "a.jpg,1,2,3,4,5\nb.jpg,north,2,3,4,5\n",
            "line 3: latitude 'north' is not a number"},
           {header + "a.jpg,200,2,3,4,5\n", "line 2: gps.lat"},
           {header + "a.jpg,1,2,3,-4,5\n", "line 2: gps.h_acc"},
           {header + "a.jpg,1,2,3,4,5\na.jpg,1,2,3,4,5\n",
            "line 3: a.jpg is already on line 2"},
           {header + "a.jpg,1\n", "line 2: latitude and longitude needed"},
           {header + ",1,2\n", "line 2: no image name"},
           {"", "empty"}}) {
    auto path = write_temp("bad.csv", c.content);
    std::string error = error_of([&] { read_gps_csv(path); });
    EXPECT_NE(error.find(c.expected), std::string::npos)
        << "got '" << error << "' for:\n"
        << c.content;
    EXPECT_NE(error.find(path), std::string::npos) << error;
  }
  EXPECT_NE(error_of([] { read_gps_csv("/nonexistent/gps.csv"); }), "");
}

// ---- GPX
// -----------------------------------------------------------------------

const char* kTrack = R"(<?xml version="1.0" encoding="UTF-8"?>
<!-- recorded by a handheld receiver <trkpt lat="0" lon="0"> -->
<gpx version="1.1" creator="test" xmlns="http://www.topografix.com/GPX/1/1"
     xmlns:gpxtpx="http://www.garmin.com/xmlschemas/TrackPointExtension/v1">
  <metadata><time>2026-11-21T00:00:00Z</time></metadata>
  <trk><name>walk &amp; talk</name>
    <trkseg>
      <trkpt lat="47.0700" lon='15.4400'>
        <ele>353.0</ele>
        <time>2026-11-21T13:05:00Z</time>
        <hdop>0.8</hdop>
        <sat>9</sat>
      </trkpt>
      <trkpt lon="15.4410" lat="47.0710">
        <ele>357.0</ele>
        <time>2026-11-21T13:05:10.500Z</time>
        <hdop>1.2</hdop>
        <sat>7</sat>
        <extensions><gpxtpx:TrackPointExtension>
          <gpxtpx:time>1999-01-01T00:00:00Z</gpxtpx:time>
        </gpxtpx:TrackPointExtension></extensions>
      </trkpt>
      <trkpt lat="47.5" lon="15.5"><ele>1</ele></trkpt>
    </trkseg>
    <trkseg>
      <trkpt lat="47.0690" lon="15.4390">
        <time>2026-11-21T14:04:50+01:00</time>
      </trkpt>
    </trkseg>
  </trk>
</gpx>
)";

TEST(Gpx, ReadsPointsSortedByTime) {
  auto track = read_gpx(write_temp("walk.gpx", kTrack));
  ASSERT_EQ(track.size(), 3u);  // the point without a time is skipped
  auto t0 = parse_time_utc("2026-11-21T13:05:00Z").value();
  EXPECT_EQ(track[0].time_s, t0 - 10);  // 14:04:50+01:00, second segment
  EXPECT_EQ(track[1].time_s, t0);
  EXPECT_EQ(track[2].time_s, t0 + 10);  // the fraction is dropped
  const GpsFix& f = track[1].fix;
  EXPECT_DOUBLE_EQ(f.lat, 47.07);
  EXPECT_DOUBLE_EQ(f.lon, 15.44);
  EXPECT_DOUBLE_EQ(f.alt.value(), 353);
  EXPECT_DOUBLE_EQ(f.h_acc.value(), 4.0);  // 5 m * hdop 0.8
  EXPECT_EQ(f.satellites.value(), 9);
  EXPECT_EQ(f.time, "2026-11-21T13:05:00Z");
  EXPECT_EQ(f.source, "gpx");
  EXPECT_EQ(track[2].fix.time, "2026-11-21T13:05:10Z");
  EXPECT_FALSE(track[0].fix.alt);
}

TEST(Gpx, ErrorsNameTheLine) {
  auto wrap = [](const std::string& points) {
    return "<gpx>\n<trk><trkseg>\n" + points + "\n</trkseg></trk></gpx>\n";
  };
  struct Case {
    std::string content;
    std::string expected;
  };
  for (const auto& c : std::vector<Case>{
           {wrap("<trkpt lat=\"1\"><time>2026-01-01T00:00:00Z</time></trkpt>"),
            "line 3: <trkpt> needs lat and lon"},
           {wrap("\n<trkpt lat=\"1\" lon=\"2\"><time>noon</time></trkpt>"),
            "line 4: <time> 'noon' is not an RFC 3339 time"},
           {wrap("<trkpt lat=\"91\" lon=\"2\">\n<time>2026-01-01T00:00:00Z"
                 "</time></trkpt>"),
            "line 3: gps.lat"},
           {wrap("<trkpt lat=\"1\" lon=\"2\"><ele>high</ele></trkpt>"),
            "line 3: <ele> 'high' is not a number"},
           {wrap("<trkpt lat=\"1\" lon=\"2\"><ele>1</ele>"),
            "unexpected </trkseg>"},
           {wrap("<trkpt lat=\"1\" lon=\"2\"/>"), "no <trkpt> with lat, lon"},
           {"<gpx><trk", "unterminated tag"}}) {
    auto path = write_temp("bad.gpx", c.content);
    std::string error = error_of([&] { read_gpx(path); });
    EXPECT_NE(error.find(c.expected), std::string::npos)
        << "got '" << error << "' for:\n"
        << c.content;
  }
  EXPECT_NE(error_of([] { read_gpx("/nonexistent/track.gpx"); }), "");
}

TEST(GpsFixAt, InterpolatesInsideAndClampsNearTheEnds) {
  auto track = read_gpx(write_temp("walk.gpx", kTrack));
  auto t0 = parse_time_utc("2026-11-21T13:05:00Z").value();

  auto exact = fix_at(track, t0);
  ASSERT_TRUE(exact);
  EXPECT_DOUBLE_EQ(exact->lat, 47.07);

  auto mid = fix_at(track, t0 + 5);
  ASSERT_TRUE(mid);
  EXPECT_NEAR(mid->lat, 47.0705, 1e-9);
  EXPECT_NEAR(mid->lon, 15.4405, 1e-9);
  EXPECT_NEAR(mid->alt.value(), 355, 1e-9);
  EXPECT_NEAR(mid->h_acc.value(), 5.0, 1e-9);  // between 4 and 6 m
  EXPECT_EQ(mid->satellites.value(), 7);       // the fewer of the two
  EXPECT_EQ(mid->time, "2026-11-21T13:05:05Z");
  EXPECT_EQ(mid->source, "gpx");

  auto before = fix_at(track, t0 - 10 - 60, 60);
  ASSERT_TRUE(before);
  EXPECT_DOUBLE_EQ(before->lat, 47.069);
  EXPECT_FALSE(fix_at(track, t0 - 10 - 61, 60));

  auto after = fix_at(track, t0 + 10 + 30, 60);
  ASSERT_TRUE(after);
  EXPECT_DOUBLE_EQ(after->lat, 47.071);
  EXPECT_FALSE(fix_at(track, t0 + 10 + 30, 29));
  EXPECT_FALSE(fix_at({}, t0));
}

TEST(GpsFixAt, CrossesTheAntimeridian) {
  std::vector<TrackPoint> track(2);
  track[0].time_s = 100;
  track[0].fix.lon = 179.5;
  track[1].time_s = 110;
  track[1].fix.lon = -179.5;
  auto fix = fix_at(track, 105);
  ASSERT_TRUE(fix);
  EXPECT_NEAR(std::abs(fix->lon), 180, 1e-9);
  EXPECT_NEAR(fix_at(track, 108)->lon, -179.7, 1e-9);
}

// ---- times
// ---------------------------------------------------------------------

TEST(GpsTime, ParsesRfc3339) {
  EXPECT_EQ(parse_time_utc("1970-01-01T00:00:00Z"), 0);
  EXPECT_EQ(parse_time_utc("2000-03-01T00:00:00Z"), 951868800);
  EXPECT_EQ(parse_time_utc("2026-11-21T13:05:00.999Z"),
            parse_time_utc("2026-11-21T13:05:00Z"));
  EXPECT_EQ(parse_time_utc("2026-11-21T14:05:00+01:00"),
            parse_time_utc("2026-11-21T13:05:00Z"));
  EXPECT_EQ(parse_time_utc("2026-11-21T12:35:00-00:30"),
            parse_time_utc("2026-11-21T13:05:00Z"));
  EXPECT_EQ(parse_time_utc("2026-11-21T13:05:00"),  // EXIF style: UTC
            parse_time_utc("2026-11-21T13:05:00Z"));
  for (const char* bad : {"", "2026-11-21", "2026-02-29T00:00:00Z",
                          "2026-13-01T00:00:00Z", "2026-11-21T24:00:00Z",
                          "2026-11-21T13:05:00.Z", "2026-11-21T13:05:00+1",
                          "2026-11-21T13:05:00Zjunk", "2026:11:21 13:05:00"})
    EXPECT_FALSE(parse_time_utc(bad)) << bad;
  EXPECT_EQ(format_time_utc(951868800), "2000-03-01T00:00:00Z");
  EXPECT_EQ(format_time_utc(-1), "1969-12-31T23:59:59Z");
  auto t = parse_time_utc("2026-11-21T13:05:07Z").value();
  EXPECT_EQ(format_time_utc(t), "2026-11-21T13:05:07Z");
}

// Found by tests/fuzz (fuzz_gps_csv): times whose offset carried them out
// of the years 0000-9999 were formatted as "-001-12-31T23:30:00Z", which
// is not RFC 3339 and did not parse again.
TEST(GpsTime, RefusesTimesOutsideTheFourDigitYears) {
  const auto first = parse_time_utc("0000-01-01T00:00:00Z");
  ASSERT_TRUE(first);
  EXPECT_EQ(format_time_utc(*first), "0000-01-01T00:00:00Z");
  const auto last = parse_time_utc("9999-12-31T23:59:59Z");
  ASSERT_TRUE(last);
  EXPECT_EQ(format_time_utc(*last), "9999-12-31T23:59:59Z");
  EXPECT_FALSE(parse_time_utc("0000-01-01T00:30:00+01:00"));
  EXPECT_FALSE(parse_time_utc("9999-12-31T23:59:60Z"));
  EXPECT_FALSE(parse_time_utc("9999-12-31T23:30:00-01:00"));
}

// ---- JSON validation
// ----------------------------------------------------------

TEST(GpsJson, RejectsInvalidFixes) {
  struct Case {
    Json json;
    std::string field;
  };
  double nan = std::numeric_limits<double>::quiet_NaN();
  double inf = std::numeric_limits<double>::infinity();
  for (const auto& c : std::vector<Case>{
           {Json{{"lat", 200}, {"lon", 15}}, "gps.lat"},
           {Json{{"lat", 47}, {"lon", -180.5}}, "gps.lon"},
           {Json{{"lat", nan}, {"lon", 15}}, "gps.lat"},
           {Json{{"lat", 47}, {"lon", 15}, {"alt", inf}}, "gps.alt"},
           {Json{{"lat", 47}, {"lon", 15}, {"h_acc", -1}}, "gps.h_acc"},
           {Json{{"lat", 47}, {"lon", 15}, {"v_acc", -0.1}}, "gps.v_acc"},
           {Json{{"lat", 47}, {"lon", 15}, {"satellites", -2}},
            "gps.satellites"},
           {Json{{"lat", 47}, {"lon", 15}, {"satellites", 7.5}},
            "gps.satellites"},
           {Json{{"lat", "47"}, {"lon", 15}}, "gps.lat"},
           {Json{{"lat", 47}}, "lat and lon"},
           {Json::array({47, 15}), "object"}}) {
    std::string error;
    EXPECT_FALSE(gps_from_json(c.json, &error)) << c.json.dump();
    EXPECT_NE(error.find(c.field), std::string::npos)
        << c.json.dump() << ": " << error;
  }
}

TEST(GpsJson, RoundTripsAValidFix) {
  GpsFix fix{.lat = 47.07,
             .lon = 15.44,
             .alt = 353.0,
             .h_acc = 3.5,
             .v_acc = 7.0,
             .satellites = 8,
             .time = "2026-11-21T13:05:00Z",
             .source = "request"};
  std::string error;
  auto back = gps_from_json(to_json(fix), &error);
  ASSERT_TRUE(back) << error;
  EXPECT_EQ(to_json(*back), to_json(fix));
  EXPECT_TRUE(validate_gps(fix).empty());
}

}  // namespace
}  // namespace arscout::metadata
