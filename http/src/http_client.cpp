// The API client over Boost.Beast. Every step (resolve, connect, TLS
// handshake, write, read) runs asynchronously on a private io_context that
// is run until the step completes: that is what lets one per-request deadline
// cover all of them, since Beast's timeouts apply only to async operations.
#include <utility>  // before Asio: Boost 1.74 uses std::exchange without it

#include <boost/asio/connect.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/ssl.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/ssl.hpp>

#include <algorithm>
#include <cctype>
#include <optional>

#include "arscout/http/client.h"

namespace arscout::http {

namespace beast = boost::beast;
namespace http = beast::http;
namespace net = boost::asio;
namespace ssl = net::ssl;
using tcp = net::ip::tcp;
using Clock = std::chrono::steady_clock;

namespace {

// Large enough for any blob the API serves (uploads are capped at 64 MiB by
// default) while still bounding what a broken server can make us buffer.
constexpr std::uint64_t kMaxResponseBody = std::uint64_t{1} << 30;
constexpr std::uint32_t kMaxResponseHeader = 64 * 1024;

struct ServerUrl {
  bool tls = false;
  std::string host;  // without brackets for IPv6
  std::string port;
  std::string host_header;  // host[:port] as the Host header wants it
  std::string base_path;    // "" or "/prefix" without a trailing slash
};

std::string lower(std::string s) {
  for (char& c : s)
    c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

void split_authority(const std::string& authority, ServerUrl* url) {
  std::string port;
  if (authority.starts_with('[')) {
    auto close = authority.find(']');
    if (close == std::string::npos) throw std::invalid_argument("missing ']'");
    url->host = authority.substr(1, close - 1);
    if (close + 1 < authority.size()) {
      if (authority[close + 1] != ':') throw std::invalid_argument("bad port");
      port = authority.substr(close + 2);
    }
  } else {
    auto colon = authority.find(':');
    url->host = authority.substr(0, colon);
    if (colon != std::string::npos) port = authority.substr(colon + 1);
  }
  if (url->host.empty()) throw std::invalid_argument("no host");
  if (!port.empty()) {
    bool digits = port.size() <= 5 &&
                  std::all_of(port.begin(), port.end(),
                              [](unsigned char c) { return std::isdigit(c); });
    if (!digits || std::stoi(port) < 1 || std::stoi(port) > 65535)
      throw std::invalid_argument("bad port '" + port + "'");
  }
  url->port = port.empty() ? (url->tls ? "443" : "80") : port;
  url->host_header = authority;
}

ServerUrl parse_server(const std::string& server) {
  ServerUrl url;
  std::string rest;
  if (lower(server.substr(0, 7)) == "http://") {
    rest = server.substr(7);
  } else if (lower(server.substr(0, 8)) == "https://") {
    url.tls = true;
    rest = server.substr(8);
  } else {
    throw std::invalid_argument("server URL '" + server +
                                "' must start with http:// or https://");
  }
  auto slash = rest.find('/');
  std::string authority = rest.substr(0, slash);
  if (slash != std::string::npos) url.base_path = rest.substr(slash);
  while (url.base_path.ends_with('/')) url.base_path.pop_back();
  if (authority.find('@') != std::string::npos)
    throw std::invalid_argument("server URL '" + server +
                                "': user info is not supported");
  try {
    split_authority(authority, &url);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument("server URL '" + server + "': " + e.what());
  }
  return url;
}

bool has_line_break(const std::string& s) {
  return s.find_first_of("\r\n") != std::string::npos;
}

// A kept-alive connection the server has since closed fails like this on
// first use, before any byte of a response arrives.
bool closed_by_peer(const beast::error_code& ec) {
  return ec == http::error::end_of_stream || ec == net::error::eof ||
         ec == net::error::connection_reset ||
         ec == net::error::connection_aborted ||
         ec == net::error::broken_pipe || ec == ssl::error::stream_truncated;
}

// A step (resolve, connect, send, ...) that failed, thrown inside Impl and
// turned into a NetworkError naming the request.
struct StepError {
  std::string what;
  beast::error_code ec;
};

}  // namespace

nlohmann::json HttpResult::json() const { return nlohmann::json::parse(body); }

struct Client::Impl {
  ClientOptions options;
  ServerUrl url;
  net::io_context ioc;
  std::optional<ssl::context> tls_context;
  std::optional<beast::tcp_stream> plain;
  std::optional<beast::ssl_stream<beast::tcp_stream>> secure;
  beast::flat_buffer buffer;

  explicit Impl(ClientOptions o)
      : options(std::move(o)), url(parse_server(options.server)) {
    // Beast reads at most the buffer's free capacity (512 bytes minimum);
    // room here makes a 3 MB download ~50 reads instead of ~6,000.
    buffer.reserve(64 * 1024);
    if (url.tls) tls_context = make_tls_context();
  }

  ~Impl() { shutdown_gracefully(); }

  ssl::context make_tls_context() const {
    ssl::context ctx(ssl::context::tls_client);
    ctx.set_options(ssl::context::default_workarounds | ssl::context::no_sslv2 |
                    ssl::context::no_sslv3 | ssl::context::no_tlsv1 |
                    ssl::context::no_tlsv1_1);
    ctx.set_default_verify_paths();
    if (!options.ca_file.empty()) {
      beast::error_code ec;
      ctx.load_verify_file(options.ca_file, ec);
      if (ec)
        throw std::runtime_error("cannot load CA file " + options.ca_file +
                                 ": " + ec.message());
    }
    ctx.set_verify_mode(options.verify_tls ? ssl::verify_peer
                                           : ssl::verify_none);
    return ctx;
  }

  bool connected() const { return plain || secure; }

  beast::tcp_stream& lowest() {
    return secure ? beast::get_lowest_layer(*secure) : *plain;
  }

  // Runs the io_context until the operations started on it are done.
  void run() {
    ioc.restart();
    ioc.run();
  }

  // Starts one async operation and waits for it; returns its error.
  template <class Start>
  beast::error_code await(Start start) {
    beast::error_code result;
    start([&result](beast::error_code ec, auto&&...) { result = ec; });
    run();
    return result;
  }

  // Applies `f` to whichever stream is open.
  template <class F>
  beast::error_code on_stream(F f) {
    if (secure) return f(*secure);
    return f(*plain);
  }

  tcp::resolver::results_type resolve(Clock::time_point deadline) {
    tcp::resolver resolver(ioc);
    net::steady_timer timer(ioc, deadline);
    bool timed_out = false;
    timer.async_wait([&](beast::error_code ec) {
      if (!ec) {
        timed_out = true;
        resolver.cancel();
      }
    });
    beast::error_code error;
    tcp::resolver::results_type results;
    resolver.async_resolve(
        url.host, url.port,
        [&](beast::error_code ec, tcp::resolver::results_type r) {
          error = ec;
          results = std::move(r);
          timer.cancel();
        });
    run();
    if (timed_out)
      throw StepError{"resolve " + url.host, beast::error::timeout};
    if (error) throw StepError{"resolve " + url.host, error};
    return results;
  }

  void connect(Clock::time_point deadline) {
    auto endpoints = resolve(deadline);
    buffer.clear();
    if (url.tls) {
      secure.emplace(ioc, *tls_context);
      prepare_tls();
    } else {
      plain.emplace(ioc);
    }
    lowest().expires_at(deadline);
    auto ec = await([&](auto handler) {
      lowest().async_connect(endpoints, std::move(handler));
    });
    if (ec) throw StepError{"connect to " + url.host_header, ec};
    lowest().socket().set_option(tcp::no_delay(true), ec);
    if (!secure) return;
    ec = await([&](auto handler) {
      secure->async_handshake(ssl::stream_base::client, std::move(handler));
    });
    if (ec) throw StepError{"TLS handshake with " + url.host_header, ec};
  }

  // SNI (not for IP literals, which RFC 6066 excludes) and the check that
  // the certificate names the host.
  void prepare_tls() {
    beast::error_code ec;
    net::ip::make_address(url.host, ec);
    if (ec &&
        !SSL_set_tlsext_host_name(secure->native_handle(), url.host.c_str()))
      throw StepError{"TLS setup",
                      beast::error_code(static_cast<int>(::ERR_get_error()),
                                        net::error::get_ssl_category())};
    if (options.verify_tls)
      secure->set_verify_callback(ssl::host_name_verification(url.host));
  }

  void disconnect() {
    if (connected()) {
      beast::error_code ec;
      lowest().socket().shutdown(tcp::socket::shutdown_both, ec);
      lowest().close();
    }
    secure.reset();
    plain.reset();
    buffer.clear();
  }

  // Sends TLS close_notify so the server sees a clean end, not a truncation.
  void shutdown_gracefully() {
    if (secure) {
      lowest().expires_after(std::chrono::seconds(1));
      await([&](auto handler) { secure->async_shutdown(std::move(handler)); });
    }
    disconnect();
  }

  // One request on the open connection. *answered says whether any byte of
  // a response arrived before a failure.
  HttpResult exchange(http::request<http::string_body>& req,
                      Clock::time_point deadline, bool* answered) {
    lowest().expires_at(deadline);
    auto ec = on_stream([&](auto& stream) {
      return await([&](auto handler) {
        http::async_write(stream, req, std::move(handler));
      });
    });
    if (ec) throw StepError{"send request", ec};
    http::response_parser<http::string_body> parser;
    parser.body_limit(kMaxResponseBody);
    parser.header_limit(kMaxResponseHeader);
    if (req.method() == http::verb::head) parser.skip(true);
    ec = on_stream([&](auto& stream) {
      return await([&](auto handler) {
        http::async_read(stream, buffer, parser, std::move(handler));
      });
    });
    *answered = parser.got_some();
    if (ec) throw StepError{"read response", ec};
    auto res = parser.release();
    if (!res.keep_alive()) disconnect();
    return to_result(res);
  }

  static HttpResult to_result(http::response<http::string_body>& res) {
    HttpResult result;
    result.status = static_cast<int>(res.result_int());
    for (const auto& field : res) {
      std::string key = lower(std::string(field.name_string()));
      std::string value(field.value());
      auto [it, fresh] = result.headers.emplace(key, value);
      if (!fresh) it->second += ", " + value;
    }
    result.body = std::move(res.body());
    return result;
  }

  http::request<http::string_body> build(
      const std::string& method, const std::string& target,
      const std::string& body,
      const std::vector<std::pair<std::string, std::string>>& headers) const {
    if (!target.starts_with('/') || has_line_break(target) ||
        target.find(' ') != std::string::npos)
      throw std::invalid_argument("bad request target '" + target + "'");
    http::request<http::string_body> req;
    req.method_string(method);
    req.target(url.base_path + target);
    req.version(11);
    req.set(http::field::host, url.host_header);
    req.set(http::field::user_agent, "arscout-client/1");
    if (!options.token.empty())
      req.set(http::field::authorization, "Bearer " + options.token);
    if (!body.empty()) req.set(http::field::content_type, "application/json");
    for (const auto& [name, value] : headers) {
      if (name.empty() || has_line_break(name) || has_line_break(value))
        throw std::invalid_argument("bad header '" + name + "'");
      req.set(name, value);
    }
    req.body() = body;
    req.prepare_payload();
    return req;
  }

  HttpResult request(http::request<http::string_body>& req) {
    auto deadline = Clock::now() + options.timeout;
    bool reused = connected();
    try {
      if (!reused) connect(deadline);
      return attempt(req, deadline);
    } catch (const StepError& e) {
      disconnect();
      if (!reused || !closed_by_peer(e.ec)) fail(req, e);
    }
    try {  // the server closed the idle connection: once more on a new one
      connect(deadline);
      return attempt(req, deadline);
    } catch (const StepError& e) {
      disconnect();
      fail(req, e);
    }
  }

  HttpResult attempt(http::request<http::string_body>& req,
                     Clock::time_point deadline) {
    bool answered = false;
    try {
      return exchange(req, deadline, &answered);
    } catch (StepError& e) {
      // Bytes of an answer mean the server got the request: not a stale
      // connection, so no silent second attempt.
      if (answered && closed_by_peer(e.ec)) e.ec = http::error::partial_message;
      throw;
    }
  }

  [[noreturn]] void fail(const http::request<http::string_body>& req,
                         const StepError& e) const {
    std::string why = e.ec == beast::error::timeout
                          ? "timed out after " +
                                std::to_string(options.timeout.count()) + " ms"
                          : e.ec.message();
    throw NetworkError(std::string(req.method_string()) + " " +
                       (url.tls ? "https://" : "http://") + url.host_header +
                       std::string(req.target()) + ": " + e.what + ": " + why);
  }
};

Client::Client(ClientOptions options) : impl_(new Impl(std::move(options))) {}

Client::~Client() { delete impl_; }

HttpResult Client::request(
    const std::string& method, const std::string& target,
    const std::string& body,
    const std::vector<std::pair<std::string, std::string>>& headers) {
  auto req = impl_->build(method, target, body, headers);
  return impl_->request(req);
}

}  // namespace arscout::http
