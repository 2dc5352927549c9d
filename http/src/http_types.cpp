#include "arscout/http/http_types.h"

namespace arscout::http {
namespace {

int hex_value(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

std::optional<std::string> percent_decode(std::string_view in,
                                          bool plus_space) {
  std::string out;
  out.reserve(in.size());
  for (std::size_t i = 0; i < in.size(); ++i) {
    char c = in[i];
    if (c == '+' && plus_space) {
      out.push_back(' ');
    } else if (c == '%') {
      if (i + 2 >= in.size()) return std::nullopt;
      int hi = hex_value(in[i + 1]), lo = hex_value(in[i + 2]);
      if (hi < 0 || lo < 0) return std::nullopt;
      out.push_back(static_cast<char>(hi * 16 + lo));
      i += 2;
    } else {
      out.push_back(c);
    }
  }
  return out;
}

}  // namespace

std::string HttpRequest::header(const std::string& lower_name) const {
  auto it = headers.find(lower_name);
  return it == headers.end() ? std::string() : it->second;
}

HttpResponse HttpResponse::geojson(const Json& body) {
  HttpResponse r = json(200, body);
  r.content_type = "application/geo+json";
  return r;
}

HttpResponse::BodyReader shared_bytes_reader(
    std::shared_ptr<const std::string> bytes) {
  HttpResponse::BodyReader reader;
  reader.size = static_cast<std::int64_t>(bytes->size());
  reader.read = [bytes = std::move(bytes)](std::int64_t offset,
                                           std::size_t length) {
    return bytes->substr(static_cast<std::size_t>(offset), length);
  };
  return reader;
}

HttpResponse HttpResponse::json(int status, const Json& body) {
  HttpResponse r;
  r.status = status;
  // Error messages quote what the client sent (a path, the JSON parser's
  // view of a body), which need not be UTF-8: such bytes become U+FFFD.
  // The strict default threw here, and thrown while Api::handle answered a
  // store error, that ended the server.
  r.body = body.dump(-1, ' ', false, Json::error_handler_t::replace);
  return r;
}

HttpResponse HttpResponse::error(int status, const std::string& kind,
                                 const std::string& message,
                                 const Json& extra) {
  Json body{{"error", kind}, {"message", message}};
  for (auto& [k, v] : extra.items()) body[k] = v;
  HttpResponse response = json(status, body);
  // A store that is down (a database restarting, a full disk being cleared)
  // is usually back within seconds; clients that honour this back off
  // instead of hammering it.
  if (status == 503) response.headers.emplace_back("Retry-After", "1");
  return response;
}

std::optional<ParsedTarget> parse_target(const std::string& target) {
  ParsedTarget out;
  std::size_t q = target.find('?');
  auto path = percent_decode(std::string_view(target).substr(0, q), false);
  if (!path) return std::nullopt;
  out.path = *path;
  if (q == std::string::npos) return out;
  std::string_view rest = std::string_view(target).substr(q + 1);
  while (!rest.empty()) {
    std::size_t amp = rest.find('&');
    std::string_view pair = rest.substr(0, amp);
    std::size_t eq = pair.find('=');
    auto key = percent_decode(pair.substr(0, eq), true);
    auto value = percent_decode(
        eq == std::string_view::npos ? std::string_view() : pair.substr(eq + 1),
        true);
    if (!key || !value) return std::nullopt;
    if (!key->empty()) out.query[*key] = *value;
    if (amp == std::string_view::npos) break;
    rest = rest.substr(amp + 1);
  }
  return out;
}

}  // namespace arscout::http
