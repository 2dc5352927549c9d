// A GPX track in time: the fix at a photo's time, interpolated between the
// track points around it (fix_at, gps.h), and the RFC 3339 times the GPS
// files and EXIF write.
#include <algorithm>

#include "arscout/metadata/gps.h"
#include "arscout/util/time.h"

namespace arscout::metadata {
namespace {

std::optional<double> lerp(const std::optional<double>& a,
                           const std::optional<double>& b, double w) {
  if (!a || !b) return std::nullopt;
  return *a + (*b - *a) * w;
}

GpsFix interpolate(const GpsFix& a, const GpsFix& b, double w) {
  GpsFix fix;
  fix.lat = a.lat + (b.lat - a.lat) * w;
  double dlon = b.lon - a.lon;
  if (dlon > 180) dlon -= 360;  // across the antimeridian
  if (dlon < -180) dlon += 360;
  fix.lon = a.lon + dlon * w;
  if (fix.lon > 180) fix.lon -= 360;
  if (fix.lon < -180) fix.lon += 360;
  fix.alt = lerp(a.alt, b.alt, w);
  fix.h_acc = lerp(a.h_acc, b.h_acc, w);
  fix.v_acc = lerp(a.v_acc, b.v_acc, w);
  if (a.satellites && b.satellites)
    fix.satellites = std::min(*a.satellites, *b.satellites);
  fix.source = a.source;
  return fix;
}

}  // namespace

std::optional<GpsFix> fix_at(const std::vector<TrackPoint>& track,
                             std::int64_t time_s, std::int64_t max_gap_s) {
  if (track.empty()) return std::nullopt;
  if (time_s <= track.front().time_s) {
    if (track.front().time_s - time_s > max_gap_s) return std::nullopt;
    return track.front().fix;
  }
  if (time_s >= track.back().time_s) {
    if (time_s - track.back().time_s > max_gap_s) return std::nullopt;
    return track.back().fix;
  }
  auto after = std::upper_bound(
      track.begin(), track.end(), time_s,
      [](std::int64_t t, const TrackPoint& p) { return t < p.time_s; });
  const TrackPoint& a = *(after - 1);
  const TrackPoint& b = *after;
  double w = static_cast<double>(time_s - a.time_s) /
             static_cast<double>(b.time_s - a.time_s);
  GpsFix fix = interpolate(a.fix, b.fix, w);
  fix.time = format_time_utc(time_s);
  return fix;
}

}  // namespace arscout::metadata
