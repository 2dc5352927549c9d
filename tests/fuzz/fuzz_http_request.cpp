// An HTTP request as the server reads and answers it, from a connection
// that delivers the input and then closes: Beast's request parser with the
// server's limits (http/src/beast_request.h), header first and then body as
// http/src/beast_session.cpp reads them, the conversion to HttpRequest, the
// target's path and query (parse_target), and then the API itself (Api::handle
// and Api::check_subscribe) on a SQLite store. The parser refuses with error
// codes and parse_target with nullopt; Api promises never to throw, and a
// 5xx answer means a handler failed unexpectedly. Anything else, a crash
// or a sanitizer report is a finding.
//
// So that requests get past authentication, the tokens "admin", "scout"
// and "planner" (as "Bearer admin" or ?access_token=admin) stand for real
// tokens of those roles. The "wait"
// parameter of long polls is dropped: waiting finds nothing.
#include <utility>  // before Asio, for C++20

#include <boost/beast/websocket/rfc6455.hpp>
#include <cctype>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <variant>

#include "api.h"
#include "api_handlers.h"
#include "arscout/http/http_types.h"
#include "arscout/ingest/auth.h"
#include "arscout/ingest/server.h"
#include "beast_request.h"
#include "fuzz_store.h"
#include "fuzz_support.h"
#include "metrics.h"

namespace {

namespace beast = boost::beast;
namespace http = beast::http;
namespace net = boost::asio;
namespace ingest = arscout::ingest;
// The server's request reading (http/src/beast_request.h); `http` is
// Beast's here.
namespace server = arscout::http;
using arscout::fuzz::check;

// http::read_header and http::read over such a connection: put what is
// there; when the parser needs more, the connection has closed.
template <typename Done>
void read_until(server::BeastRequestParser& parser, net::const_buffer& rest,
                Done done, beast::error_code& ec) {
  while (!done()) {
    if (rest.size() > 0) {
      const std::size_t used = parser.put(rest, ec);
      rest += used;
      if (ec != http::error::need_more) {
        if (ec) return;
        continue;
      }
    }
    ec = {};
    if (!parser.got_some()) {
      ec = http::error::end_of_stream;
      return;
    }
    parser.put_eof(ec);
    return;
  }
}

bool unreserved(unsigned char c) {
  return std::isalnum(c) || c == '-' || c == '.' || c == '_' || c == '~';
}

std::string encode(std::string_view text, bool keep_slash) {
  static constexpr char kHex[] = "0123456789ABCDEF";
  std::string out;
  for (unsigned char c : text) {
    if (unreserved(c) || (keep_slash && c == '/')) {
      out += static_cast<char>(c);
    } else {
      out += '%';
      out += kHex[c >> 4];
      out += kHex[c & 15];
    }
  }
  return out;
}

// parse_target inverts percent-encoding: encoding what it decoded and
// parsing that again gives the same path and parameters.
void check_target_round_trip(const arscout::http::ParsedTarget& parsed) {
  std::string target = encode(parsed.path, true);
  char separator = '?';
  for (const auto& [key, value] : parsed.query) {
    target += separator;
    target += encode(key, false) + "=" + encode(value, false);
    separator = '&';
  }
  const auto again = arscout::http::parse_target(target);
  check(again.has_value(), "an encoded target parses");
  check(again->path == parsed.path, "the path survives a round trip");
  check(again->query == parsed.query, "the query survives a round trip");
}

// What the API reads from a request before a handler runs.
void check_api_view(const ingest::Api& api,
                    const arscout::http::HttpRequest& req) {
  const std::string route = api.route_template(req.method, req.path);
  check(!route.empty(), "every request has a route name for the metrics");
  for (const char* name : {"since", "limit", "depth", "wait"}) {
    std::string error;
    const auto value = ingest::int_param(req, name, 7, -5, 1000, &error);
    check(value.has_value() == error.empty(),
          "int_param sets an error exactly when it fails");
    if (value) check(*value >= -5 && *value <= 1000, "int_param keeps range");
  }
  for (const auto& [name, value] : req.headers) {
    for (char c : name)
      check(!(c >= 'A' && c <= 'Z'), "header names are lower case");
    check(req.header(name) == value, "header() finds every header");
  }
}

// The API on a scratch store, with a token per role.
class ApiUnderTest {
 public:
  ingest::Api& next() {
    bool fresh = false;
    arscout::db::Store& store = scratch_.next(&fresh);
    if (fresh) {
      api_ = std::make_unique<ingest::Api>(store, metrics_);
      tokens_.clear();
      for (auto [name, role] : {std::pair{"admin", ingest::Role::kAdmin},
                                {"scout", ingest::Role::kScout},
                                {"planner", ingest::Role::kPlanner}})
        tokens_[name] = ingest::create_token(store, role, name);
    }
    return *api_;
  }

  void authorize(arscout::http::HttpRequest& req) const {
    if (auto header = req.headers.find("authorization");
        header != req.headers.end() && header->second.starts_with("Bearer ")) {
      if (auto token = tokens_.find(header->second.substr(7));
          token != tokens_.end())
        header->second = "Bearer " + token->second;
    }
    if (auto query = req.query.find("access_token"); query != req.query.end())
      if (auto token = tokens_.find(query->second); token != tokens_.end())
        query->second = token->second;
  }

 private:
  arscout::fuzz::ScratchStore scratch_;
  ingest::Metrics metrics_;
  std::unique_ptr<ingest::Api> api_;
  std::map<std::string, std::string> tokens_;
};

void check_answer(const arscout::http::HttpResponse& response) {
  if (response.status >= 200 && response.status < 500) return;
  std::fprintf(stderr, "answered %d: %s\n", response.status,
               response.body.c_str());
  arscout::fuzz::fail("the API answers a request 2xx, 3xx or 4xx");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data,
                                      std::size_t size) {
  static const ingest::ServerOptions options;
  static ApiUnderTest api_under_test;
  server::BeastRequestParser parser;
  server::limit_request_parser(parser, options);
  net::const_buffer rest(data, size);
  beast::error_code ec;

  // HttpSession::read_header and on_header.
  parser.eager(false);
  read_until(
      parser, rest, [&] { return parser.is_header_done(); }, ec);
  if (ec) return 0;  // 431, 413 or a dropped connection
  const auto length = parser.content_length();
  if (length && *length > options.max_body_bytes) return 0;  // 413
  if (beast::websocket::is_upgrade(parser.get())) {
    // HttpSession::upgrade reads the target of the header alone.
    arscout::http::HttpRequest req =
        server::to_request(server::BeastRequest(parser.release()));
    auto parsed = arscout::http::parse_target(req.target);
    if (!parsed) return 0;
    check_target_round_trip(*parsed);
    req.path = std::move(parsed->path);
    req.query = std::move(parsed->query);
    if (req.path != "/v1/subscribe") return 0;  // 404
    ingest::Api& api = api_under_test.next();
    api_under_test.authorize(req);
    auto checked = api.check_subscribe(req);
    if (auto* refusal = std::get_if<arscout::http::HttpResponse>(&checked))
      check_answer(*refusal);
    return 0;
  }

  // HttpSession::read_body and on_body.
  parser.eager(true);
  read_until(
      parser, rest, [&] { return parser.is_done(); }, ec);
  if (ec) return 0;
  arscout::http::HttpRequest req = server::to_request(parser.release());
  check(req.body.size() <= options.max_body_bytes, "the body limit holds");
  check(!req.method.empty(), "a parsed request has a method");
  auto parsed = arscout::http::parse_target(req.target);
  if (!parsed) return 0;  // 400
  check_target_round_trip(*parsed);
  req.path = std::move(parsed->path);
  req.query = std::move(parsed->query);

  // HttpSession::on_body hands the request to the API.
  ingest::Api& api = api_under_test.next();
  check_api_view(api, req);
  api_under_test.authorize(req);
  req.query.erase("wait");
  check_answer(api.handle(req));
  return 0;
}
