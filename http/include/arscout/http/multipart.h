// multipart/form-data (RFC 7578) bodies: just what capture uploads need.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace arscout::http {

struct FormPart {
  std::string name;          // from Content-Disposition
  std::string filename;      // may be empty
  std::string content_type;  // may be empty
  std::string_view body;     // points into the request body
};

// The boundary parameter of a multipart/form-data Content-Type, or "".
std::string multipart_boundary(const std::string& content_type);

// Splits body into its parts. Returns nullopt and sets *error on a
// malformed body (missing boundary lines, parts without a name, no final
// boundary).
std::optional<std::vector<FormPart>> parse_multipart(
    std::string_view body, const std::string& boundary, std::string* error);

}  // namespace arscout::http
