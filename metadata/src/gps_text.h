// Number parsing shared by the GPS file readers (gps_csv.cpp, gps_gpx.cpp):
// files written by hand and by many devices, so surrounding blanks and a
// leading '+' are forgiven.
#pragma once

#include <charconv>
#include <cmath>
#include <optional>
#include <string_view>

namespace arscout::metadata::gps_text {

inline std::string_view trim(std::string_view s) {
  auto first = s.find_first_not_of(" \t\r\n");
  if (first == std::string_view::npos) return {};
  return s.substr(first, s.find_last_not_of(" \t\r\n") - first + 1);
}

// A finite number filling all of `s` (after trimming), else nullopt.
inline std::optional<double> parse_double(std::string_view s) {
  s = trim(s);
  if (!s.empty() && s[0] == '+') s.remove_prefix(1);
  double v = 0;
  auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (s.empty() || ec != std::errc() || end != s.data() + s.size() ||
      !std::isfinite(v))
    return std::nullopt;
  return v;
}

// An int filling all of `s` (after trimming), else nullopt.
inline std::optional<int> parse_int(std::string_view s) {
  s = trim(s);
  int v = 0;
  auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (s.empty() || ec != std::errc() || end != s.data() + s.size())
    return std::nullopt;
  return v;
}

}  // namespace arscout::metadata::gps_text
