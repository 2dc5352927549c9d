// Request bodies as JSON, parsed in one pass with their nesting bounded:
// a body comes from an untrusted client (docs/RELIABILITY.md).
#pragma once

#include <optional>
#include <string>

#include "arscout/http/http_types.h"

namespace arscout::http {

// Parses a JSON body; nullopt and *error (naming the byte) when malformed,
// nested more than 512 levels deep or holding a number beyond a double's
// range.
std::optional<Json> parse_json_body(const std::string& text,
                                    std::string* error);

}  // namespace arscout::http
