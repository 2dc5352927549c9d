// RFC 3339 times, as stored documents and GPS files write them.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace arscout::util {

// Seconds since the Unix epoch of "YYYY-MM-DDTHH:MM:SS[.fff][Z|+hh:mm|-hh:mm]"
// (RFC 3339; fractions are dropped; "t" and " " are accepted for "T"). A time
// without an offset, such as an EXIF DateTimeOriginal, is read as UTC.
// nullopt when malformed, or outside the years 0000 to 9999 once the offset
// is applied.
std::optional<std::int64_t> parse_time_utc(std::string_view text);

// "YYYY-MM-DDTHH:MM:SSZ".
std::string format_time_utc(std::int64_t time_s);

}  // namespace arscout::util
