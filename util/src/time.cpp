#include "arscout/util/time.h"

#include <chrono>
#include <cstdio>

namespace arscout::util {
namespace {

std::string_view trim(std::string_view s) {
  auto first = s.find_first_not_of(" \t\r\n");
  if (first == std::string_view::npos) return {};
  return s.substr(first, s.find_last_not_of(" \t\r\n") - first + 1);
}

// Exactly `n` digits at s[pos..]; advances pos.
bool digits(std::string_view s, std::size_t& pos, int n, int* out) {
  if (pos + n > s.size()) return false;
  int v = 0;
  for (int i = 0; i < n; ++i) {
    char c = s[pos + i];
    if (c < '0' || c > '9') return false;
    v = v * 10 + (c - '0');
  }
  pos += n;
  *out = v;
  return true;
}

bool expect(std::string_view s, std::size_t& pos, std::string_view chars) {
  if (pos >= s.size() || chars.find(s[pos]) == std::string_view::npos)
    return false;
  ++pos;
  return true;
}

// The "Z", "+hh:mm" or "-hh:mm" at the end, as seconds east of UTC.
std::optional<int> utc_offset(std::string_view s, std::size_t pos) {
  if (pos == s.size()) return 0;
  if (s.substr(pos) == "Z" || s.substr(pos) == "z") return 0;
  const int sign = s[pos] == '-' ? -1 : 1;
  int h, m;
  if (!expect(s, pos, "+-") || !digits(s, pos, 2, &h) || !expect(s, pos, ":") ||
      !digits(s, pos, 2, &m) || pos != s.size() || h > 23 || m > 59)
    return std::nullopt;
  return sign * (h * 3600 + m * 60);
}

// Skips ".fff" at pos, if there; false for a dot without digits.
bool skip_fraction(std::string_view s, std::size_t& pos) {
  if (pos >= s.size() || s[pos] != '.') return true;
  const std::size_t start = ++pos;
  while (pos < s.size() && s[pos] >= '0' && s[pos] <= '9') ++pos;
  return pos != start;
}

}  // namespace

std::optional<std::int64_t> parse_time_utc(std::string_view text) {
  const std::string_view s = trim(text);
  std::size_t pos = 0;
  int y = 0, mo = 0, d = 0, h = 0, mi = 0, sec = 0;
  if (!digits(s, pos, 4, &y) || !expect(s, pos, "-") ||
      !digits(s, pos, 2, &mo) || !expect(s, pos, "-") ||
      !digits(s, pos, 2, &d) || !expect(s, pos, "Tt ") ||
      !digits(s, pos, 2, &h) || !expect(s, pos, ":") ||
      !digits(s, pos, 2, &mi) || !expect(s, pos, ":") ||
      !digits(s, pos, 2, &sec) || h > 23 || mi > 59 || sec > 60 ||
      !skip_fraction(s, pos))
    return std::nullopt;
  auto offset = utc_offset(s, pos);
  namespace chr = std::chrono;
  chr::year_month_day date{chr::year{y}, chr::month(static_cast<unsigned>(mo)),
                           chr::day(static_cast<unsigned>(d))};
  if (!offset || !date.ok()) return std::nullopt;
  std::int64_t days = chr::sys_days(date).time_since_epoch().count();
  std::int64_t time_s = days * 86400 + h * 3600 + mi * 60 + sec - *offset;
  // An offset or a leap second can carry a time out of the years 0000 to
  // 9999, which format_time_utc cannot write as RFC 3339 again.
  constexpr std::int64_t kFirst = -62167219200;  // 0000-01-01T00:00:00Z
  constexpr std::int64_t kLast = 253402300799;   // 9999-12-31T23:59:59Z
  if (time_s < kFirst || time_s > kLast) return std::nullopt;
  return time_s;
}

std::string format_time_utc(std::int64_t time_s) {
  namespace chr = std::chrono;
  chr::sys_seconds t{chr::seconds(time_s)};
  auto day = chr::floor<chr::days>(t);
  chr::year_month_day date{day};
  chr::hh_mm_ss hms{t - day};
  char buf[48];
  std::snprintf(
      buf, sizeof buf, "%04d-%02u-%02uT%02d:%02d:%02dZ",
      static_cast<int>(date.year()), static_cast<unsigned>(date.month()),
      static_cast<unsigned>(date.day()), static_cast<int>(hms.hours().count()),
      static_cast<int>(hms.minutes().count()),
      static_cast<int>(hms.seconds().count()));
  return buf;
}

}  // namespace arscout::util
