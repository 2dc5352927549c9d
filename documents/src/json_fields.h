// Checks on JSON field values shared by the forms' readers.
#pragma once

#include <optional>
#include <string>

#include <nlohmann/json.hpp>

namespace arscout::documents::fields {

using Json = nlohmann::json;

bool is_finite_number(const Json& j);
// A finite whole number in [min, 1e9].
bool is_whole_number(const Json& j, double min);

// The value of `key` when present and not null; nullptr otherwise.
const Json* find(const Json& object, const char* key);

// The string at `key`, or `fallback` when absent, null or not a string.
std::string string_or(const Json& object, const char* key,
                      const std::string& fallback = "");
// The finite number at `key`, else nullopt.
std::optional<double> number(const Json& object, const char* key);

}  // namespace arscout::documents::fields
