// A GPX track from a separate receiver (read_gpx,
// metadata/include/arscout/metadata/gps.h), read from a scratch file since the
// reader takes a path, and the fixes interpolated from it (fix_at). A malformed
// file must end in std::runtime_error; a good track is sorted by time, its
// points valid with their canonical time, and fix_at answers anywhere along it.
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "arscout/metadata/gps.h"
#include "fuzz_support.h"

namespace {

namespace metadata = arscout::metadata;
using arscout::fuzz::check;

void check_interpolated(const std::vector<metadata::TrackPoint>& track,
                        std::int64_t time_s) {
  const auto fix = metadata::fix_at(track, time_s, 60);
  check(fix.has_value(), "fix_at answers inside the track");
  check(std::isfinite(fix->lat) && std::isfinite(fix->lon),
        "an interpolated fix has a position");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data,
                                      std::size_t size) {
  static arscout::fuzz::ScratchFile file(".gpx");
  const std::string& path = file.write(arscout::fuzz::as_text(data, size));
  std::vector<metadata::TrackPoint> track;
  try {
    track = metadata::read_gpx(path);
  } catch (const std::runtime_error&) {
    return 0;  // the documented refusal
  }
  check(!track.empty(), "a track that reads has a point");
  for (std::size_t i = 0; i < track.size(); ++i) {
    const metadata::TrackPoint& p = track[i];
    if (i > 0) check(track[i - 1].time_s <= p.time_s, "a track is sorted");
    check(metadata::validate_gps(p.fix).empty(), "a GPX fix is valid");
    check(p.fix.source == "gpx", "a GPX fix says where it came from");
    check(p.fix.time == metadata::format_time_utc(p.time_s),
          "a GPX fix's time is its point's");
    const auto t = metadata::parse_time_utc(p.fix.time);
    check(t && *t == p.time_s, "a GPX fix's time reads back");
  }
  const std::int64_t first = track.front().time_s;
  const std::int64_t last = track.back().time_s;
  check_interpolated(track, first);
  check_interpolated(track, last);
  check_interpolated(track, first + (last - first) / 2);
  check(!metadata::fix_at(track, first - 61, 60) &&
            !metadata::fix_at(track, last + 61, 60),
        "fix_at refuses times beyond the gap");
  return 0;
}
