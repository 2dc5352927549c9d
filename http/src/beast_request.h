// How the server reads an HTTP request with Boost.Beast: the parser's limits
// and the conversion to HttpRequest. Header-only, so that Beast stays in the
// translation units that compile it already (beast_session.cpp) and the
// HTTP fuzz target (tests/fuzz), which must parse exactly as the server
// does.
#pragma once

#include <utility>  // before Asio, for C++20

#include <boost/beast/http.hpp>
#include <cctype>
#include <cstdint>
#include <string>

#include "arscout/http/http_types.h"
#include "arscout/http/server.h"

namespace arscout::http {

using BeastRequest =
    boost::beast::http::request<boost::beast::http::string_body>;
using BeastRequestParser =
    boost::beast::http::request_parser<boost::beast::http::string_body>;

// A fresh parser for each request: Beast's parsers read one message only.
inline void limit_request_parser(BeastRequestParser& parser,
                                 const ServerLimits& limits) {
  parser.header_limit(static_cast<std::uint32_t>(limits.max_header_bytes));
  parser.body_limit(limits.max_body_bytes);
}

// Method, target and headers (names lower-cased), without the body: what
// is known once the header has been read.
inline HttpRequest head_of(const BeastRequest& in) {
  HttpRequest out;
  out.method = std::string(in.method_string());
  out.target = std::string(in.target());
  for (const auto& field : in) {
    std::string name(field.name_string());
    for (char& c : name) c = static_cast<char>(std::tolower(c));
    out.headers[name] = std::string(field.value());
  }
  return out;
}

// Method, target, headers and body; path and query are left to
// parse_target, whose failure the caller answers.
inline HttpRequest to_request(BeastRequest&& in) {
  HttpRequest out = head_of(in);
  out.body = std::move(in.body());
  return out;
}

// Why a request's Transfer-Encoding cannot be read, or "". Only "chunked"
// is: Beast frames any other coding as a body-less request, so the bytes
// meant as its body would be read as the next request (request smuggling
// behind a proxy that frames them otherwise). RFC 9112 6.1 asks for 400
// and closing.
inline std::string transfer_encoding_problem(const BeastRequest& in) {
  auto field = in.find(boost::beast::http::field::transfer_encoding);
  if (field == in.end()) return "";
  std::string value(field->value());
  const auto first = value.find_first_not_of(" \t");
  const auto last = value.find_last_not_of(" \t");
  value =
      first == std::string::npos ? "" : value.substr(first, last - first + 1);
  for (char& c : value) c = static_cast<char>(std::tolower(c));
  if (value == "chunked" &&
      in.count(boost::beast::http::field::transfer_encoding) == 1)
    return "";
  return "Transfer-Encoding '" + std::string(field->value()) +
         "' is not supported: only a single 'chunked'";
}

}  // namespace arscout::http
