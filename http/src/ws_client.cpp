// ChangeStream: a WebSocket client of /v1/subscribe. A reader thread moves
// frames into a queue that next() drains.
#include <utility>  // before Asio, for C++20

#include <boost/asio.hpp>
#include <boost/asio/ssl.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/ssl.hpp>
#include <boost/beast/websocket.hpp>
#include <boost/beast/websocket/ssl.hpp>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <thread>

#include "arscout/http/change_stream.h"

namespace arscout::http {
namespace {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace websocket = beast::websocket;
namespace ssl = asio::ssl;
using tcp = asio::ip::tcp;

struct Endpoint {
  bool tls = false;
  std::string host;
  std::string port;
};

Endpoint parse_server(const std::string& server) {
  Endpoint e;
  std::string rest;
  if (server.rfind("https://", 0) == 0) {
    e.tls = true;
    rest = server.substr(8);
  } else if (server.rfind("http://", 0) == 0) {
    rest = server.substr(7);
  } else {
    throw NetworkError("server URL must start with http:// or https://: " +
                       server);
  }
  if (auto slash = rest.find('/'); slash != std::string::npos)
    rest = rest.substr(0, slash);
  auto colon = rest.rfind(':');
  e.host = colon == std::string::npos ? rest : rest.substr(0, colon);
  e.port = colon == std::string::npos ? (e.tls ? "443" : "80")
                                      : rest.substr(colon + 1);
  return e;
}

std::string query_escape(const std::string& s) {
  static const char* hex = "0123456789ABCDEF";
  std::string out;
  for (unsigned char c : s) {
    if (std::isalnum(c) || c == '/' || c == '*' || c == '-' || c == '_' ||
        c == '.') {
      out.push_back(static_cast<char>(c));
    } else {
      out += '%';
      out += hex[c >> 4];
      out += hex[c & 15];
    }
  }
  return out;
}

}  // namespace

struct ChangeStream::Impl {
  asio::io_context ioc;
  ssl::context tls{ssl::context::tls_client};
  std::unique_ptr<websocket::stream<beast::tcp_stream>> plain;
  std::unique_ptr<websocket::stream<ssl::stream<beast::tcp_stream>>> secure;
  std::thread reader;
  std::mutex mu;
  std::condition_variable cv;
  std::deque<nlohmann::json> frames;
  std::string ended;  // why the connection ended; empty while open

  template <typename Ws>
  void handshake(Ws& ws, const Endpoint& e, const std::string& target,
                 const std::string& token) {
    ws.set_option(websocket::stream_base::decorator(
        [token](websocket::request_type& req) {
          if (!token.empty()) req.set("Authorization", "Bearer " + token);
        }));
    websocket::response_type response;
    beast::error_code ec;
    ws.handshake(response, e.host + ":" + e.port, target, ec);
    if (ec)
      throw NetworkError("WebSocket upgrade refused (HTTP " +
                         std::to_string(response.result_int()) +
                         "): " + response.body());
  }

  template <typename Ws>
  void read_loop(Ws& ws) {
    beast::flat_buffer buffer;
    while (true) {
      beast::error_code ec;
      ws.read(buffer, ec);
      std::lock_guard lock(mu);
      if (ec) {
        ended = "the change stream ended: " + ec.message();
        cv.notify_all();
        return;
      }
      auto j = nlohmann::json::parse(beast::buffers_to_string(buffer.data()),
                                     nullptr, false);
      buffer.consume(buffer.size());
      if (!j.is_discarded()) frames.push_back(std::move(j));
      cv.notify_all();
    }
  }

  void close() {
    beast::error_code ignored;
    if (plain)
      beast::get_lowest_layer(*plain).socket().shutdown(
          tcp::socket::shutdown_both, ignored);
    if (secure)
      beast::get_lowest_layer(*secure).socket().shutdown(
          tcp::socket::shutdown_both, ignored);
    if (reader.joinable()) reader.join();
  }
};

ChangeStream::ChangeStream(const ClientOptions& options, std::int64_t since,
                           const std::string& pattern)
    : impl_(std::make_unique<Impl>()) {
  Endpoint e = parse_server(options.server);
  std::string target = "/v1/subscribe?since=" + std::to_string(since) +
                       "&pattern=" + query_escape(pattern);
  tcp::resolver resolver(impl_->ioc);
  beast::error_code ec;
  auto addresses = resolver.resolve(e.host, e.port, ec);
  if (ec) throw NetworkError("cannot resolve " + e.host + ": " + ec.message());
  if (e.tls) {
    impl_->tls.set_default_verify_paths();
    if (!options.ca_file.empty()) impl_->tls.load_verify_file(options.ca_file);
    impl_->tls.set_verify_mode(options.verify_tls ? ssl::verify_peer
                                                  : ssl::verify_none);
    impl_->secure =
        std::make_unique<websocket::stream<ssl::stream<beast::tcp_stream>>>(
            impl_->ioc, impl_->tls);
    auto& layer = beast::get_lowest_layer(*impl_->secure);
    layer.connect(addresses, ec);
    if (!ec)
      SSL_set_tlsext_host_name(impl_->secure->next_layer().native_handle(),
                               e.host.c_str());
    if (!ec)
      impl_->secure->next_layer().handshake(ssl::stream_base::client, ec);
    if (ec)
      throw NetworkError("cannot connect to " + options.server + ": " +
                         ec.message());
    impl_->handshake(*impl_->secure, e, target, options.token);
    impl_->reader = std::thread([this] { impl_->read_loop(*impl_->secure); });
  } else {
    impl_->plain =
        std::make_unique<websocket::stream<beast::tcp_stream>>(impl_->ioc);
    beast::get_lowest_layer(*impl_->plain).connect(addresses, ec);
    if (ec)
      throw NetworkError("cannot connect to " + options.server + ": " +
                         ec.message());
    impl_->handshake(*impl_->plain, e, target, options.token);
    impl_->reader = std::thread([this] { impl_->read_loop(*impl_->plain); });
  }
}

ChangeStream::~ChangeStream() { impl_->close(); }

std::optional<nlohmann::json> ChangeStream::next(
    std::chrono::milliseconds timeout) {
  std::unique_lock lock(impl_->mu);
  impl_->cv.wait_for(lock, timeout, [&] {
    return !impl_->frames.empty() || !impl_->ended.empty();
  });
  if (!impl_->frames.empty()) {
    nlohmann::json j = std::move(impl_->frames.front());
    impl_->frames.pop_front();
    return j;
  }
  if (!impl_->ended.empty()) throw NetworkError(impl_->ended);
  return std::nullopt;
}

}  // namespace arscout::http
