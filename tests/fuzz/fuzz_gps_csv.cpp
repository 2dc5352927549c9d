// The GPS CSV a scout brings along (read_gps_csv,
// metadata/include/arscout/metadata/gps.h), read from a scratch file since the
// reader takes a path. A malformed file must end in std::runtime_error; the
// fixes of a good one must be valid, carry a canonical time, and survive the
// JSON form capture documents store.
#include <cstdint>
#include <map>
#include <stdexcept>
#include <string>

#include "arscout/metadata/gps.h"
#include "fuzz_gps.h"
#include "fuzz_support.h"

namespace {

namespace metadata = arscout::metadata;
using arscout::fuzz::check;
using arscout::fuzz::same_fix;

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data,
                                      std::size_t size) {
  static arscout::fuzz::ScratchFile file(".csv");
  const std::string& path = file.write(arscout::fuzz::as_text(data, size));
  std::map<std::string, metadata::GpsFix> fixes;
  try {
    fixes = metadata::read_gps_csv(path);
  } catch (const std::runtime_error&) {
    return 0;  // the documented refusal
  }
  for (const auto& [image, fix] : fixes) {
    check(!image.empty(), "every fix names its image");
    check(metadata::validate_gps(fix).empty(), "a CSV fix is valid");
    check(fix.source == "csv", "a CSV fix says where it came from");
    if (!fix.time.empty()) {
      const auto t = metadata::parse_time_utc(fix.time);
      check(t.has_value() && metadata::format_time_utc(*t) == fix.time,
            "a CSV fix's time is canonical RFC 3339");
    }
    std::string error;
    const auto again = metadata::gps_from_json(to_json(fix), &error);
    check(again.has_value() && same_fix(*again, fix),
          "a CSV fix survives its JSON form");
  }
  return 0;
}
