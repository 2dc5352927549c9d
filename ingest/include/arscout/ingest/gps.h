// GPS fixes and where they come from: the upload request, the image's EXIF,
// a CSV of fixes per image, or a GPX track matched by photo time.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

namespace arscout::ingest {

using Json = nlohmann::json;

// One fix, WGS84. Accuracies are 1-sigma metres as the receiver reports
// them; `time` is RFC 3339 UTC or empty; `source` says where it came from:
// "request", "exif", "csv", "gpx".
struct GpsFix {
  double lat = 0;
  double lon = 0;
  std::optional<double> alt;  // ellipsoidal height, metres
  std::optional<double> h_acc;
  std::optional<double> v_acc;
  std::optional<int> satellites;
  std::string time;
  std::string source;
};

// {"lat", "lon", "alt"?, "h_acc"?, "v_acc"?, "satellites"?, "time"?,
//  "source"?}: the form stored in capture documents (attrs.gps).
Json to_json(const GpsFix& fix);
// Parses and validates that form (source is left as given). Returns nullopt
// and sets *error naming the field when it is invalid: lat/lon missing or
// out of range, NaN/infinite values, negative accuracies or satellites.
std::optional<GpsFix> gps_from_json(const Json& j, std::string* error);
// The same checks on a fix built in code ("" when valid).
std::string validate_gps(const GpsFix& fix);

// What the EXIF of a JPEG (or PNG with an eXIf chunk) says, as far as it
// says it. Never throws on bad metadata: fields stay empty.
struct ExifInfo {
  std::optional<GpsFix> gps;  // source "exif"
  std::string taken;          // DateTimeOriginal, "YYYY-MM-DDTHH:MM:SS"
  std::optional<double> focal_mm;
  std::optional<double> focal_35mm;         // 35 mm equivalent focal length
  std::optional<double> focal_plane_x_res;  // pixels per unit
  std::optional<double> focal_plane_unit_mm;
  std::string make;
  std::string model;
  int width = 0;  // from EXIF, 0 if absent
  int height = 0;
};
ExifInfo read_exif(std::string_view image_bytes);
ExifInfo read_exif_file(const std::string& path);

// A CSV like ../shared/data/strecha/*/gps.csv:
//   image,latitude,longitude,altitude,horizontal_accuracy_m,vertical_accuracy_m
// Returns image file name -> fix (source "csv"). Throws std::runtime_error
// naming the line of a malformed row.
std::map<std::string, GpsFix> read_gps_csv(const std::string& path);

// A GPX 1.0/1.1 track (trkpt with lat/lon, ele, time, hdop, sat), sorted by
// time. h_acc (v_acc) is 5 m times hdop (vdop). Points without a time are
// skipped; throws std::runtime_error naming the line of a malformed point,
// or when no point has a time.
struct TrackPoint {
  std::int64_t time_s = 0;  // seconds since the Unix epoch, UTC
  GpsFix fix;
};
std::vector<TrackPoint> read_gpx(const std::string& path);
// The fix at `time_s`, interpolated between the track points around it;
// nullopt when the time is more than max_gap_s outside the track.
std::optional<GpsFix> fix_at(const std::vector<TrackPoint>& track,
                             std::int64_t time_s, std::int64_t max_gap_s = 60);

// Seconds since the Unix epoch of "YYYY-MM-DDTHH:MM:SS[.fff][Z|+hh:mm|-hh:mm]"
// (RFC 3339; fractions are dropped). A time without an offset, such as
// ExifInfo::taken, is read as UTC. nullopt when malformed or out of range.
std::optional<std::int64_t> parse_time_utc(std::string_view text);
// "YYYY-MM-DDTHH:MM:SSZ".
std::string format_time_utc(std::int64_t time_s);

}  // namespace arscout::ingest
