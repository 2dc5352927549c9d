// Where each photo's request GPS comes from (--gps-csv, --gpx).
#include <cmath>

#include "scout_internal.h"

namespace arscout::scout::detail {

GpsSource::GpsSource(const ScoutOptions& options) : options_(options) {
  if (!options.gps_csv.empty()) csv_ = read_gps_csv(options.gps_csv);
  if (!options.gpx.empty()) track_ = read_gpx(options.gpx);
}

std::optional<GpsFix> GpsSource::fix_for(const std::string& file_name,
                                         const ExifInfo& exif,
                                         std::string* why) const {
  if (!options_.gps_csv.empty()) return from_csv(file_name, why);
  if (!options_.gpx.empty()) return from_gpx(exif, why);
  return std::nullopt;
}

std::optional<std::int64_t> GpsSource::taken_utc(const ExifInfo& exif) const {
  auto t = parse_time_utc(exif.taken);
  if (!t) return std::nullopt;
  return *t - std::llround(options_.time_offset_s.value_or(0));
}

std::optional<GpsFix> GpsSource::from_csv(const std::string& file_name,
                                          std::string* why) const {
  auto it = csv_.find(file_name);
  if (it != csv_.end()) return it->second;
  *why = "no row in " +
         std::filesystem::path(options_.gps_csv).filename().string();
  return std::nullopt;
}

std::optional<GpsFix> GpsSource::from_gpx(const ExifInfo& exif,
                                          std::string* why) const {
  auto t = taken_utc(exif);
  if (!t) {
    *why = "no EXIF DateTimeOriginal to match the GPX track";
    return std::nullopt;
  }
  auto fix = fix_at(track_, *t, std::llround(options_.gpx_max_gap_s));
  if (!fix) *why = "taken " + format_time_utc(*t) + ", off the track";
  return fix;
}

}  // namespace arscout::scout::detail
