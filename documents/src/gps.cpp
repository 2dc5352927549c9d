#include "arscout/documents/gps.h"

#include <cmath>
#include <cstdint>

#include "arscout/util/time.h"
#include "json_fields.h"

namespace arscout::documents {
namespace {

using fields::Json;

// Reads an optional finite number; false (with *error) when present but bad.
bool optional_number(const Json& j, const char* key, std::optional<double>* out,
                     std::string* error) {
  const Json* value = fields::find(j, key);
  if (!value) return true;
  if (!fields::is_finite_number(*value)) {
    *error = std::string("gps.") + key + " must be a finite number";
    return false;
  }
  *out = value->get<double>();
  return true;
}

// satellites, time and source into *fix; "" or what is wrong.
std::string read_details(const Json& j, GpsFix* fix) {
  if (const Json* sats = fields::find(j, "satellites")) {
    // Range-checked before narrowing: 2^32 + 1 must not become 1.
    if (!sats->is_number_integer() || sats->get<double>() < 0 ||
        sats->get<double>() > 255)
      return "gps.satellites must be a count in [0, 255]";
    fix->satellites = static_cast<int>(sats->get<std::int64_t>());
  }
  if (const Json* time = fields::find(j, "time")) {
    if (!time->is_string() || time->get<std::string>().size() > 64 ||
        !util::parse_time_utc(time->get<std::string>()))
      return "gps.time must be an RFC 3339 time (2026-11-21T13:05:00Z)";
    fix->time = time->get<std::string>();
  }
  fix->source = fields::string_or(j, "source");
  return "";
}

std::optional<GpsFix> parse(const Json& j, std::string* error) {
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
  *error = read_details(j, &fix);
  if (error->empty()) *error = validate_gps(fix);
  if (!error->empty()) return std::nullopt;
  return fix;
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
  std::string ignored;
  return parse(j, error ? error : &ignored);
}

}  // namespace arscout::documents
