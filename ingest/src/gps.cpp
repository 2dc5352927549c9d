#include "arscout/ingest/gps.h"

#include <cmath>

namespace arscout::ingest {
namespace {

// Reads an optional finite number; false (with *error) when present but bad.
bool optional_number(const Json& j, const char* key, std::optional<double>* out,
                     std::string* error) {
  auto it = j.find(key);
  if (it == j.end() || it->is_null()) return true;
  if (!it->is_number() || !std::isfinite(it->get<double>())) {
    *error = std::string("gps.") + key + " must be a finite number";
    return false;
  }
  *out = it->get<double>();
  return true;
}

}  // namespace

Json to_json(const GpsFix& fix) {
  Json j{{"lat", fix.lat}, {"lon", fix.lon}};
  if (fix.alt) j["alt"] = *fix.alt;
  if (fix.h_acc) j["h_acc"] = *fix.h_acc;
  if (fix.v_acc) j["v_acc"] = *fix.v_acc;
  if (fix.satellites) j["satellites"] = *fix.satellites;
  if (!fix.time.empty()) j["time"] = fix.time;
  if (!fix.source.empty()) j["source"] = fix.source;
  return j;
}

std::string validate_gps(const GpsFix& fix) {
  if (!std::isfinite(fix.lat) || fix.lat < -90 || fix.lat > 90)
    return "gps.lat must be a latitude in [-90, 90]";
  if (!std::isfinite(fix.lon) || fix.lon < -180 || fix.lon > 180)
    return "gps.lon must be a longitude in [-180, 180]";
  if (fix.alt && (!std::isfinite(*fix.alt) || std::abs(*fix.alt) > 100000))
    return "gps.alt must be a height in metres within +-100 km";
  for (auto [name, acc] : {std::pair{"h_acc", fix.h_acc}, {"v_acc", fix.v_acc}})
    if (acc && (!std::isfinite(*acc) || *acc < 0))
      return std::string("gps.") + name + " must be a finite accuracy >= 0 m";
  if (fix.satellites && (*fix.satellites < 0 || *fix.satellites > 255))
    return "gps.satellites must be a count in [0, 255]";
  return "";
}

std::optional<GpsFix> gps_from_json(const Json& j, std::string* error) {
  if (!j.is_object()) {
    *error = "gps must be a JSON object";
    return std::nullopt;
  }
  GpsFix fix;
  std::optional<double> lat, lon;
  if (!optional_number(j, "lat", &lat, error) ||
      !optional_number(j, "lon", &lon, error) ||
      !optional_number(j, "alt", &fix.alt, error) ||
      !optional_number(j, "h_acc", &fix.h_acc, error) ||
      !optional_number(j, "v_acc", &fix.v_acc, error))
    return std::nullopt;
  if (!lat || !lon) {
    *error = "gps needs both lat and lon";
    return std::nullopt;
  }
  fix.lat = *lat;
  fix.lon = *lon;
  if (auto it = j.find("satellites"); it != j.end() && !it->is_null()) {
    // Range-checked before narrowing: 2^32 + 1 must not become 1.
    if (!it->is_number_integer() || it->get<double>() < 0 ||
        it->get<double>() > 255) {
      *error = "gps.satellites must be a count in [0, 255]";
      return std::nullopt;
    }
    fix.satellites = static_cast<int>(it->get<std::int64_t>());
  }
  if (auto it = j.find("time"); it != j.end() && !it->is_null()) {
    if (!it->is_string() || it->get<std::string>().size() > 64 ||
        !parse_time_utc(it->get<std::string>())) {
      *error = "gps.time must be an RFC 3339 time (2026-11-21T13:05:00Z)";
      return std::nullopt;
    }
    fix.time = it->get<std::string>();
  }
  if (auto it = j.find("source"); it != j.end() && it->is_string())
    fix.source = it->get<std::string>();
  *error = validate_gps(fix);
  if (!error->empty()) return std::nullopt;
  return fix;
}

}  // namespace arscout::ingest
