#include "arscout/http/multipart.h"

#include <algorithm>
#include <cctype>

namespace arscout::http {
namespace {

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  return s;
}

// The value of `key="..."` (or key=token) in a header value, or "".
std::string header_param(const std::string& value, const std::string& key) {
  std::string lowered = lower(value);
  std::size_t pos = 0;
  while ((pos = lowered.find(key + "=", pos)) != std::string::npos) {
    bool starts =
        pos == 0 || lowered[pos - 1] == ';' || lowered[pos - 1] == ' ';
    std::size_t start = pos + key.size() + 1;
    if (!starts) {
      pos = start;
      continue;
    }
    if (start < value.size() && value[start] == '"') {
      std::size_t end = value.find('"', start + 1);
      if (end == std::string::npos) return "";
      return value.substr(start + 1, end - start - 1);
    }
    std::size_t end = value.find(';', start);
    std::string token = value.substr(start, end - start);
    while (!token.empty() && token.back() == ' ') token.pop_back();
    return token;
  }
  return "";
}

bool parse_part_headers(std::string_view head, FormPart* part) {
  std::size_t pos = 0;
  while (pos < head.size()) {
    std::size_t eol = head.find("\r\n", pos);
    if (eol == std::string_view::npos) eol = head.size();
    std::string line(head.substr(pos, eol - pos));
    pos = eol + 2;
    std::size_t colon = line.find(':');
    if (colon == std::string::npos) continue;
    std::string name = lower(line.substr(0, colon));
    std::string value = line.substr(colon + 1);
    value.erase(0, value.find_first_not_of(' '));
    if (name == "content-disposition") {
      part->name = header_param(value, "name");
      part->filename = header_param(value, "filename");
    } else if (name == "content-type") {
      part->content_type = lower(value);
    }
  }
  return !part->name.empty();
}

}  // namespace

std::string multipart_boundary(const std::string& content_type) {
  if (lower(content_type).rfind("multipart/form-data", 0) != 0) return "";
  return header_param(content_type, "boundary");
}

std::optional<std::vector<FormPart>> parse_multipart(
    std::string_view body, const std::string& boundary, std::string* error) {
  if (boundary.empty() || boundary.size() > 200) {
    *error = "multipart body without a valid boundary";
    return std::nullopt;
  }
  const std::string delimiter = "--" + boundary;
  std::vector<FormPart> parts;
  std::size_t pos = body.find(delimiter);
  if (pos == std::string_view::npos) {
    *error = "multipart body does not contain its boundary";
    return std::nullopt;
  }
  while (true) {
    pos += delimiter.size();
    if (body.substr(pos, 2) == "--") return parts;  // the final boundary
    if (body.substr(pos, 2) != "\r\n") {
      *error = "malformed multipart boundary line";
      return std::nullopt;
    }
    pos += 2;
    std::size_t head_end = body.find("\r\n\r\n", pos);
    if (head_end == std::string_view::npos) {
      *error = "multipart part without a header end";
      return std::nullopt;
    }
    FormPart part;
    if (!parse_part_headers(body.substr(pos, head_end - pos), &part)) {
      *error = "multipart part without a Content-Disposition name";
      return std::nullopt;
    }
    std::size_t data = head_end + 4;
    std::size_t next = body.find("\r\n" + delimiter, data);
    if (next == std::string_view::npos) {
      *error = "multipart body ends before its final boundary";
      return std::nullopt;
    }
    part.body = body.substr(data, next - data);
    parts.push_back(part);
    pos = next + 2;
  }
}

}  // namespace arscout::http
