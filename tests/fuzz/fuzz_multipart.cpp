// multipart/form-data capture uploads (http/include/arscout/http/multipart.h).
// The input's first line is the Content-Type header, the rest the body. A
// malformed body must end in nullopt with an error; the parts of a well-formed
// one must lie inside the body, in order, each named. Parts whose names and
// types are plain tokens must survive being written out again and parsed.
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "arscout/http/multipart.h"
#include "fuzz_support.h"

namespace {

namespace http = arscout::http;
using arscout::fuzz::check;

bool plain_token(std::string_view s) {
  for (char c : s) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') ||
                    (c >= '0' && c <= '9') || c == '.' || c == '_' ||
                    c == '-' || c == '/';
    if (!ok) return false;
  }
  return true;
}

std::string write_form(const std::vector<http::FormPart>& parts,
                       const std::string& boundary) {
  std::string body = "preamble\r\n";
  for (const http::FormPart& p : parts) {
    body += "--" + boundary + "\r\n";
    body += "Content-Disposition: form-data; name=\"" + p.name + "\"";
    if (!p.filename.empty()) body += "; filename=\"" + p.filename + "\"";
    body += "\r\n";
    if (!p.content_type.empty())
      body += "Content-Type: " + p.content_type + "\r\n";
    body += "\r\n";
    body.append(p.body);
    body += "\r\n";
  }
  return body + "--" + boundary + "--\r\nepilogue";
}

void check_round_trip(const std::vector<http::FormPart>& parts,
                      const std::string& boundary) {
  if (parts.empty()) return;  // "--b--" alone has no first boundary line
  for (const http::FormPart& p : parts)
    if (!plain_token(p.name) || !plain_token(p.filename) ||
        !plain_token(p.content_type))
      return;
  const std::string body = write_form(parts, boundary);
  std::string error;
  const auto again = http::parse_multipart(body, boundary, &error);
  check(again.has_value(), "a written form parses");
  check(again->size() == parts.size(), "a written form keeps its parts");
  for (std::size_t i = 0; i < parts.size(); ++i) {
    check((*again)[i].name == parts[i].name, "a part keeps its name");
    check((*again)[i].filename == parts[i].filename,
          "a part keeps its file name");
    check((*again)[i].content_type == parts[i].content_type,
          "a part keeps its type");
    check((*again)[i].body == parts[i].body, "a part keeps its bytes");
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data,
                                      std::size_t size) {
  const std::string_view input = arscout::fuzz::as_text(data, size);
  const std::size_t newline = input.find('\n');
  if (newline == std::string_view::npos) return 0;
  const std::string content_type(input.substr(0, newline));
  // It ends where libFuzzer's copy of the input ends, which ASan guards.
  const std::string_view view = input.substr(newline + 1);

  const std::string boundary = http::multipart_boundary(content_type);
  std::string error;
  const auto parts = http::parse_multipart(view, boundary, &error);
  check(parts.has_value() == error.empty(),
        "parse_multipart sets an error exactly when it fails");
  if (!parts) return 0;
  const char* previous_end = view.data();
  for (const http::FormPart& p : *parts) {
    check(!p.name.empty(), "every part has a name");
    check(p.body.data() >= previous_end &&
              p.body.data() + p.body.size() <= view.data() + view.size(),
          "parts lie inside the body, in order");
    previous_end = p.body.data() + p.body.size();
  }
  check_round_trip(*parts, boundary);
  return 0;
}
