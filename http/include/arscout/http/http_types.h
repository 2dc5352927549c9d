// Plain HTTP request and response values. The API handlers see only these,
// so only the server's session (http/src/beast_session.cpp) compiles
// Boost.Beast; routes added by other libraries (ServerOptions::routes) see
// them too. Knows nothing of the store: ingest/store_errors.h maps its
// errors to responses.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

namespace arscout::http {

using Json = nlohmann::json;

struct HttpRequest {
  std::string method;                          // "GET", "POST", ...
  std::string target;                          // as sent: path?query
  std::string path;                            // percent-decoded, no query
  std::map<std::string, std::string> query;    // percent-decoded
  std::map<std::string, std::string> headers;  // keys lower-case
  std::string body;
  // Set by a server that holds long-polls without a thread: GET
  // /v1/changes then never blocks, and answers with
  // HttpResponse::park_after when it has nothing to show yet.
  bool may_park = false;
  std::string remote;  // the client's address, for the access log

  // A header's value, or "" when absent.
  std::string header(const std::string& lower_name) const;
};

struct HttpResponse {
  int status = 200;
  std::string content_type = "application/json";
  std::vector<std::pair<std::string, std::string>> headers;
  std::string body;
  // A body sent in pieces instead of `body`, each read as the client takes
  // the one before: blobs and exports, which may be far larger than one
  // connection should hold (the server keeps one piece per connection, and
  // a bounded sum over all). read(offset, length) runs on a worker and
  // returns from 1 to `length` bytes (fewer where the source prefers to
  // stop, as at a chunk of the store; the next read goes on from there);
  // it may throw, and then the connection closes mid-body (the status is
  // already sent).
  struct BodyReader {
    std::int64_t size = 0;
    std::function<std::string(std::int64_t offset, std::size_t length)> read;
  };
  std::optional<BodyReader> body_reader;
  // Not an answer yet (only to a request with may_park): nothing to show;
  // ask again once the change log is past this seq, or when the wait ends.
  std::optional<std::int64_t> park_after;

  static HttpResponse json(int status, const Json& body);
  // 200 with a GeoJSON body (RFC 7946), as application/geo+json.
  static HttpResponse geojson(const Json& body);
  // {"error": kind, "message": message} plus any fields of `extra`.
  static HttpResponse error(int status, const std::string& kind,
                            const std::string& message,
                            const Json& extra = Json::object());
};

// A body reader over bytes held in memory and shared (a cached export):
// every connection that sends them reads the one copy.
HttpResponse::BodyReader shared_bytes_reader(
    std::shared_ptr<const std::string> bytes);

// Splits a request target into a decoded path and query parameters. Returns
// nullopt for malformed percent-encoding.
struct ParsedTarget {
  std::string path;
  std::map<std::string, std::string> query;
};
std::optional<ParsedTarget> parse_target(const std::string& target);

}  // namespace arscout::http
