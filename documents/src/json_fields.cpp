#include "json_fields.h"

#include <cmath>

namespace arscout::documents::fields {

bool is_finite_number(const Json& j) {
  return j.is_number() && std::isfinite(j.get<double>());
}

bool is_whole_number(const Json& j, double min) {
  if (!is_finite_number(j)) return false;
  const double v = j.get<double>();
  return v >= min && v == std::floor(v) && v <= 1e9;
}

const Json* find(const Json& object, const char* key) {
  if (!object.is_object()) return nullptr;
  auto it = object.find(key);
  return it == object.end() || it->is_null() ? nullptr : &*it;
}

std::string string_or(const Json& object, const char* key,
                      const std::string& fallback) {
  const Json* value = find(object, key);
  return value && value->is_string() ? value->get<std::string>() : fallback;
}

std::optional<double> number(const Json& object, const char* key) {
  const Json* value = find(object, key);
  if (!value || !is_finite_number(*value)) return std::nullopt;
  return value->get<double>();
}

}  // namespace arscout::documents::fields
