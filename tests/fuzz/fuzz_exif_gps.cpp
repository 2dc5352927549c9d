// The EXIF of an uploaded photo (read_exif,
// metadata/include/arscout/metadata/gps.h), through exiv2. read_exif promises
// never to throw whatever the bytes: an exception escaping is a finding. What
// it returns must be usable as it is: a GPS fix that passes validate_gps and
// survives the JSON form capture documents store, sizes and focal lengths in
// their ranges.
#include <cmath>
#include <cstdint>
#include <string>

#include "arscout/metadata/gps.h"
#include "fuzz_gps.h"
#include "fuzz_support.h"

namespace {

namespace metadata = arscout::metadata;
using arscout::fuzz::check;
using arscout::fuzz::same_fix;

void check_positive(const std::optional<double>& v, const char* what) {
  if (v) check(std::isfinite(*v) && *v > 0, what);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data,
                                      std::size_t size) {
  const metadata::ExifInfo info =
      metadata::read_exif(arscout::fuzz::as_text(data, size));
  if (info.gps) {
    check(metadata::validate_gps(*info.gps).empty(), "an EXIF fix is valid");
    check(info.gps->source == "exif", "an EXIF fix says where it came from");
    std::string error;
    const auto again = metadata::gps_from_json(to_json(*info.gps), &error);
    check(again.has_value() && same_fix(*again, *info.gps),
          "an EXIF fix survives its JSON form");
    if (!info.gps->time.empty())
      check(metadata::parse_time_utc(info.gps->time).has_value(),
            "an EXIF fix's time is an RFC 3339 time");
  }
  if (!info.taken.empty())
    check(info.taken.size() == 19 && metadata::parse_time_utc(info.taken),
          "taken is a time YYYY-MM-DDTHH:MM:SS");
  check_positive(info.focal_mm, "the focal length is positive");
  check_positive(info.focal_35mm, "the 35 mm focal length is positive");
  check_positive(info.focal_plane_x_res, "the focal plane resolution is > 0");
  check_positive(info.focal_plane_unit_mm, "the focal plane unit is > 0");
  check(info.width >= 0 && info.width <= 1000000, "the width is in range");
  check(info.height >= 0 && info.height <= 1000000, "the height is in range");
  return 0;
}
