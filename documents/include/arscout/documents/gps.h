// The GPS fix form: a capture's attrs.gps (docs/api.md), also the body's
// "gps" of an upload. WGS84.
#pragma once

#include <optional>
#include <string>

#include <nlohmann/json_fwd.hpp>

namespace arscout::documents {

// Accuracies are 1-sigma metres as the receiver reports them; `time` is
// RFC 3339 UTC or empty; `source` says where the fix came from: "request",
// "exif", "csv", "gpx".
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
//  "source"?}.
nlohmann::json to_json(const GpsFix& fix);

// Parses and validates that form (source is kept as given). Returns nullopt
// and, when `error` is given, sets *error naming the field when it is
// invalid: not an object, lat/lon missing or out of range, NaN or infinite
// values, negative accuracies or satellites, a time that is not RFC 3339.
std::optional<GpsFix> gps_from_json(const nlohmann::json& j,
                                    std::string* error = nullptr);

// The same checks on a fix built in code ("" when valid).
std::string validate_gps(const GpsFix& fix);

}  // namespace arscout::documents
