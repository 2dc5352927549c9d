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

#include "arscout/documents/gps.h"
#include "arscout/util/time.h"

namespace arscout::metadata {

using Json = nlohmann::json;

// The fix form stored in capture documents (attrs.gps) is
// documents::GpsFix, with its one JSON writer and reader.
using documents::gps_from_json;
using documents::GpsFix;
using documents::to_json;
using documents::validate_gps;

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
// or when no point has a time. Read as XML (expat), from an untrusted
// source: also throws for XML that is not well-formed, a DOCTYPE that
// declares entities, or a file over 256 MiB. A file cut off between points
// (a logger that lost power) keeps its complete points.
struct TrackPoint {
  std::int64_t time_s = 0;  // seconds since the Unix epoch, UTC
  GpsFix fix;
};
std::vector<TrackPoint> read_gpx(const std::string& path);
// The fix at `time_s`, interpolated between the track points around it;
// nullopt when the time is more than max_gap_s outside the track.
std::optional<GpsFix> fix_at(const std::vector<TrackPoint>& track,
                             std::int64_t time_s, std::int64_t max_gap_s = 60);

// RFC 3339 times (util/time.h), as the GPS readers and capture documents
// write them.
using util::format_time_utc;
using util::parse_time_utc;

}  // namespace arscout::metadata
