// The network side of the server, and the only server file that compiles
// Boost.Beast: accepting, TLS, HTTP/1.1 sessions with limits and timeouts,
// WebSocket subscriptions. Requests are answered by Api on a worker pool.
#include <utility>  // before Asio, for C++20

#include <spdlog/spdlog.h>
#include <boost/asio.hpp>
#include <boost/asio/ssl.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/ssl.hpp>
#include <boost/beast/websocket.hpp>
#include <boost/beast/websocket/ssl.hpp>
#include <deque>
#include <mutex>
#include <optional>
#include <thread>

#include "api.h"
#include "api_handlers.h"
#include "arscout/ingest/server.h"
#include "beast_request.h"

namespace arscout::ingest {
namespace {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
namespace ssl = asio::ssl;
using tcp = asio::ip::tcp;

// Where a WebSocket session's subscription posts changes: the session's
// strand, until the server stops. The subscription (its thread and its
// callback) can outlive the io_context: sessions hand it to the worker pool
// to stop, and the pool goes last. A strand executor must not outlive its
// io_context, so the server drops these copies while the context exists.
struct FeedTarget {
  std::mutex mu;
  std::optional<asio::any_io_executor> executor;  // reset when stopping
};

class FeedTargets {
 public:
  std::shared_ptr<FeedTarget> add(asio::any_io_executor executor) {
    auto target = std::make_shared<FeedTarget>();
    target->executor = std::move(executor);
    std::lock_guard lock(mu_);
    std::erase_if(targets_, [](const auto& t) { return t.expired(); });
    targets_.push_back(target);
    return target;
  }
  // After this no change is posted any more, and no copy of an executor of
  // the io_context is left with the subscriptions.
  void close_all() {
    std::lock_guard lock(mu_);
    for (const auto& weak : targets_)
      if (auto target = weak.lock()) {
        std::lock_guard target_lock(target->mu);
        target->executor.reset();
      }
    targets_.clear();
  }

 private:
  std::mutex mu_;
  std::vector<std::weak_ptr<FeedTarget>> targets_;
};

struct Shared {
  Api& api;
  const ServerOptions& options;
  asio::thread_pool& workers;
  FeedTargets& feeds;
};

http::response<http::string_body> to_beast(HttpResponse&& r, unsigned version,
                                           bool keep_alive) {
  http::response<http::string_body> out{static_cast<http::status>(r.status),
                                        version};
  out.set(http::field::server, "arscout/0.1");
  out.set(http::field::content_type, r.content_type);
  for (auto& [k, v] : r.headers) out.set(k, v);
  out.body() = std::move(r.body);
  out.keep_alive(keep_alive);
  out.prepare_payload();
  return out;
}

// Socket access for both stream kinds.
tcp::socket& socket_of(beast::tcp_stream& s) { return s.socket(); }
tcp::socket& socket_of(beast::ssl_stream<beast::tcp_stream>& s) {
  return s.next_layer().socket();
}
beast::tcp_stream& tcp_of(beast::tcp_stream& s) { return s; }
beast::tcp_stream& tcp_of(beast::ssl_stream<beast::tcp_stream>& s) {
  return s.next_layer();
}

// ---------------------------------------------------------------- WebSocket

template <typename Stream>
class SubscribeSession
    : public std::enable_shared_from_this<SubscribeSession<Stream>> {
 public:
  SubscribeSession(Stream&& stream, Shared shared)
      : ws_(std::move(stream)), shared_(shared) {
    shared_.api.metrics().connection_opened();
  }
  ~SubscribeSession() {
    shared_.api.metrics().connection_closed();
    // Stopping joins the subscription thread; never on a network thread.
    if (subscription_) {
      auto sub = std::shared_ptr<db::Subscription>(std::move(subscription_));
      asio::post(shared_.workers, [sub] { sub->stop(); });
    }
  }

  void run(http::request<http::string_body> upgrade, Api::Subscribe where) {
    tcp_of(beast::get_lowest_layer(ws_)).expires_never();
    ws_.set_option(
        websocket::stream_base::timeout::suggested(beast::role_type::server));
    auto self = this->shared_from_this();
    ws_.async_accept(upgrade, [self, where](beast::error_code ec) {
      if (ec) return;
      self->start_feed(where);
      self->read_loop();
      self->recheck_token(where.authorization);
    });
  }

 private:
  static constexpr std::size_t kMaxQueued = 20000;

  // Every second the stream's token is looked up again (on a worker: it
  // reads the store); once it is revoked or expired the stream closes.
  void recheck_token(std::string authorization) {
    recheck_.expires_after(std::chrono::seconds(1));
    recheck_.async_wait(
        [self = this->shared_from_this(), authorization](beast::error_code ec) {
          if (ec) return;  // cancelled: the stream ended
          asio::post(self->shared_.workers, [self, authorization] {
            bool valid = true;  // a store that cannot answer revokes nothing
            try {
              valid = authenticate(self->shared_.api.store(), authorization)
                          .has_value();
            } catch (const std::exception&) {
            }
            asio::post(self->ws_.get_executor(), [self, valid, authorization] {
              if (valid) return self->recheck_token(authorization);
              self->ws_.async_close(
                  websocket::close_reason(websocket::close_code::policy_error,
                                          "the token was revoked or expired"),
                  [self](beast::error_code) {});
            });
          });
        });
  }

  void start_feed(const Api::Subscribe& where) {
    std::weak_ptr<SubscribeSession> weak = this->shared_from_this();
    auto target = shared_.feeds.add(ws_.get_executor());
    subscription_ = shared_.api.store().subscribe(
        where.pattern, where.since,
        [weak, target, who = where.who](const db::Change& c) {
          if (!can_read(who, c.path)) return;  // as the documents themselves
          std::string text = to_json(c).dump();
          std::lock_guard lock(target->mu);
          if (!target->executor) return;  // the server is stopping
          asio::post(*target->executor,
                     [weak, text = std::move(text)]() mutable {
                       if (auto self = weak.lock())
                         self->enqueue(std::move(text));
                     });
        });
  }

  // The client sends nothing we need; reading notices when it goes away.
  void read_loop() {
    auto self = this->shared_from_this();
    ws_.async_read(incoming_, [self](beast::error_code ec, std::size_t) {
      if (ec) {  // closed: the session ends with its last owner
        self->recheck_.cancel();
        return;
      }
      self->incoming_.consume(self->incoming_.size());
      self->read_loop();
    });
  }

  void enqueue(std::string text) {
    if (queue_.size() >= kMaxQueued) {  // a client too slow to keep up
      ws_.async_close(
          websocket::close_reason(websocket::close_code::policy_error,
                                  "too far behind; reconnect "
                                  "with since"),
          [self = this->shared_from_this()](beast::error_code) {});
      return;
    }
    queue_.push_back(std::move(text));
    if (queue_.size() == 1) write_next();
  }

  void write_next() {
    ws_.text(true);
    auto self = this->shared_from_this();
    ws_.async_write(asio::buffer(queue_.front()),
                    [self](beast::error_code ec, std::size_t) {
                      if (ec) return;
                      self->queue_.pop_front();
                      if (!self->queue_.empty()) self->write_next();
                    });
  }

  websocket::stream<Stream> ws_;
  Shared shared_;
  asio::steady_timer recheck_{ws_.get_executor()};
  beast::flat_buffer incoming_;
  std::deque<std::string> queue_;
  std::unique_ptr<db::Subscription> subscription_;
};

// ---------------------------------------------------------------- HTTP

template <typename Stream>
class HttpSession : public std::enable_shared_from_this<HttpSession<Stream>> {
 public:
  HttpSession(Stream&& stream, Shared shared)
      : stream_(std::move(stream)), shared_(shared) {
    shared_.api.metrics().connection_opened();
    // Beast reads at most the buffer's free capacity (512 bytes minimum),
    // and the body parser empties it after each read: without room here a
    // 3 MB upload takes ~6,000 reads.
    buffer_.reserve(kReadChunk);
  }
  ~HttpSession() { shared_.api.metrics().connection_closed(); }

  void run() {
    if constexpr (std::is_same_v<Stream, beast::tcp_stream>) {
      read_header(shared_.options.header_timeout);
    } else {
      tcp_of(stream_).expires_after(shared_.options.header_timeout);
      stream_.async_handshake(
          ssl::stream_base::server,
          [self = this->shared_from_this()](beast::error_code ec) {
            if (!ec) self->read_header(self->shared_.options.header_timeout);
          });
    }
  }

 private:
  static constexpr std::size_t kReadChunk = 64 * 1024;

  void read_header(std::chrono::seconds timeout) {
    parser_.emplace();
    limit_request_parser(*parser_, shared_.options);
    tcp_of(stream_).expires_after(timeout);
    http::async_read_header(
        stream_, buffer_, *parser_,
        [self = this->shared_from_this()](beast::error_code ec, std::size_t) {
          self->on_header(ec);
        });
  }

  void on_header(beast::error_code ec) {
    if (ec == http::error::header_limit)
      return reject(431, "header_too_large",
                    "the request header is larger than " +
                        std::to_string(shared_.options.max_header_bytes) +
                        " bytes");
    if (ec == http::error::body_limit) return reject_too_large();
    if (ec) return;  // closed, timed out or garbage: drop the connection
    if (std::string problem = transfer_encoding_problem(parser_->get());
        !problem.empty())
      return reject(400, "bad_request", problem);
    auto length = parser_->content_length();
    if (length && *length > shared_.options.max_body_bytes)
      return reject_too_large();
    if (websocket::is_upgrade(parser_->get())) return upgrade();
    if (parser_->is_done()) return read_body();  // no body to protect
    check_before_body();
  }

  // A body is read only from a client the request's header already
  // authorises: a missing or unknown token, or a role that may not make
  // the request, is answered (and the connection closed) before the body
  // and before any "100 Continue", so an unauthenticated client cannot
  // make the server take in megabytes. The token is checked on a worker
  // (it reads the store), then the session goes on on its own strand.
  void check_before_body() {
    HttpRequest head = head_of(parser_->get());
    auto parsed = parse_target(head.target);
    if (!parsed) return continue_body();  // on_body answers the bad URL
    head.path = std::move(parsed->path);
    auto self = this->shared_from_this();
    asio::post(shared_.workers, [self, head = std::move(head)] {
      auto refusal = self->shared_.api.refuse_before_body(head);
      asio::post(self->stream_.get_executor(),
                 [self, refusal = std::move(refusal)]() mutable {
                   if (refusal) return self->refuse(std::move(*refusal));
                   self->continue_body();
                 });
    });
  }

  void continue_body() {
    auto length = parser_->content_length();
    auto body_time = std::chrono::seconds(30) +
                     std::chrono::seconds(length.value_or(0) / (64 * 1024));
    tcp_of(stream_).expires_after(body_time);
    if (beast::iequals(parser_->get()[http::field::expect], "100-continue"))
      return send_continue();
    read_body();
  }

  // Answers, then closes: the unread body is not this connection's to skip.
  void refuse(HttpResponse&& response) {
    send(std::move(response), parser_->get().version(), false);
  }

  // Clients such as curl send "Expect: 100-continue" with large bodies and
  // wait (a second, for curl) for this interim answer before sending.
  void send_continue() {
    auto interim = std::make_shared<http::response<http::empty_body>>(
        http::status::continue_, parser_->get().version());
    http::async_write(stream_, *interim,
                      [self = this->shared_from_this(), interim](
                          beast::error_code ec, std::size_t) {
                        if (!ec) self->read_body();
                      });
  }

  void read_body() {
    http::async_read(
        stream_, buffer_, *parser_,
        [self = this->shared_from_this()](beast::error_code ec, std::size_t) {
          self->on_body(ec);
        });
  }

  void on_body(beast::error_code ec) {
    if (ec == http::error::body_limit) return reject_too_large();
    if (ec) return;
    tcp_of(stream_).expires_never();
    auto request = parser_->release();
    const unsigned version = request.version();
    const bool keep_alive = request.keep_alive();
    HttpRequest req = to_request(std::move(request));
    auto parsed = parse_target(req.target);
    if (!parsed) {
      return send(HttpResponse::error(400, "bad_request",
                                      "malformed percent-encoding in the URL"),
                  version, false);
    }
    req.path = std::move(parsed->path);
    req.query = std::move(parsed->query);
    auto self = this->shared_from_this();
    asio::post(shared_.workers, [self, req = std::move(req), version,
                                 keep_alive]() mutable {
      HttpResponse response = self->shared_.api.handle(req);
      asio::post(self->stream_.get_executor(),
                 [self, response = std::move(response), version,
                  keep_alive]() mutable {
                   self->send(std::move(response), version, keep_alive);
                 });
    });
  }

  void upgrade() {
    auto request = parser_->release();
    HttpRequest req = to_request(http::request<http::string_body>(request));
    auto parsed = parse_target(req.target);
    if (parsed) {
      req.path = parsed->path;
      req.query = parsed->query;
    }
    if (!parsed || req.path != "/v1/subscribe")
      return send(HttpResponse::error(404, "not_found",
                                      "WebSocket only at /v1/subscribe"),
                  request.version(), false);
    auto checked = shared_.api.check_subscribe(req);
    if (auto* error = std::get_if<HttpResponse>(&checked))
      return send(std::move(*error), request.version(), false);
    auto ws =
        std::make_shared<SubscribeSession<Stream>>(std::move(stream_), shared_);
    ws->run(std::move(request), std::get<Api::Subscribe>(checked));
  }

  void reject_too_large() {
    reject(413, "payload_too_large",
           "the request body is larger than the limit of " +
               std::to_string(shared_.options.max_body_bytes) + " bytes");
  }

  // Answers without reading the rest of the request, then closes.
  void reject(int status, const std::string& kind, const std::string& message) {
    shared_.api.metrics().record_request("rejected", status, 0);
    send(HttpResponse::error(status, kind, message), 11, false);
  }

  void send(HttpResponse&& response, unsigned version, bool keep_alive) {
    auto message = std::make_shared<http::response<http::string_body>>(
        to_beast(std::move(response), version, keep_alive));
    tcp_of(stream_).expires_after(std::chrono::seconds(60));
    http::async_write(stream_, *message,
                      [self = this->shared_from_this(), message](
                          beast::error_code ec, std::size_t) {
                        if (ec) return;
                        if (!message->keep_alive()) return self->close();
                        self->read_header(self->shared_.options.idle_timeout);
                      });
  }

  void close() {
    beast::error_code ignored;
    socket_of(stream_).shutdown(tcp::socket::shutdown_send, ignored);
  }

  Stream stream_;
  Shared shared_;
  beast::flat_buffer buffer_;
  std::optional<BeastRequestParser> parser_;
};

}  // namespace

struct Server::Impl {
  Impl(db::Store& store, ServerOptions opts)
      : options(std::move(opts)),
        api(store, metrics, options.routes, options.static_mounts),
        workers(static_cast<std::size_t>(std::max(1, options.worker_threads))),
        acceptor(ioc),
        tls_context(ssl::context::tls_server) {}

  void load_tls() {
    if (options.tls_cert.empty() != options.tls_key.empty())
      throw std::runtime_error("--tls-cert and --tls-key go together");
    if (options.tls_cert.empty()) return;
    use_tls = true;
    tls_context.set_options(ssl::context::default_workarounds |
                            ssl::context::no_sslv2 | ssl::context::no_sslv3 |
                            ssl::context::no_tlsv1 | ssl::context::no_tlsv1_1);
    boost::system::error_code ec;
    tls_context.use_certificate_chain_file(options.tls_cert, ec);
    if (ec)
      throw std::runtime_error("cannot load TLS certificate " +
                               options.tls_cert + ": " + ec.message());
    tls_context.use_private_key_file(options.tls_key, ssl::context::pem, ec);
    if (ec)
      throw std::runtime_error("cannot load TLS key " + options.tls_key + ": " +
                               ec.message());
  }

  void listen() {
    boost::system::error_code ec;
    auto address = asio::ip::make_address(options.host, ec);
    if (ec) throw std::runtime_error("invalid listen address " + options.host);
    tcp::endpoint endpoint(address, options.port);
    acceptor.open(endpoint.protocol(), ec);
    if (!ec) acceptor.set_option(asio::socket_base::reuse_address(true), ec);
    if (!ec) acceptor.bind(endpoint, ec);
    if (!ec) acceptor.listen(asio::socket_base::max_listen_connections, ec);
    if (ec)
      throw std::runtime_error("cannot listen on " + options.host + ":" +
                               std::to_string(options.port) + ": " +
                               ec.message());
    bound_port = acceptor.local_endpoint().port();
  }

  void accept() {
    acceptor.async_accept(asio::make_strand(ioc), [this](beast::error_code ec,
                                                         tcp::socket socket) {
      if (ec == asio::error::operation_aborted) return;
      if (!ec) {
        Shared shared{api, options, workers, feeds};
        if (use_tls) {
          std::make_shared<HttpSession<beast::ssl_stream<beast::tcp_stream>>>(
              beast::ssl_stream<beast::tcp_stream>(
                  beast::tcp_stream(std::move(socket)), tls_context),
              shared)
              ->run();
        } else {
          std::make_shared<HttpSession<beast::tcp_stream>>(
              beast::tcp_stream(std::move(socket)), shared)
              ->run();
        }
      }
      accept();
    });
  }

  ServerOptions options;
  Metrics metrics;
  Api api;
  // Before the io_context, so it is destroyed after it: sessions still
  // queued there when the server stops post their subscription's stop()
  // to the workers as they go, and the pool must still exist to take it
  // (dropping the task then stops the subscription before the store can go).
  asio::thread_pool workers;
  FeedTargets feeds;
  asio::io_context ioc;
  tcp::acceptor acceptor;
  ssl::context tls_context;
  bool use_tls = false;
  std::uint16_t bound_port = 0;
  std::vector<std::thread> threads;
};

Server::Server(db::Store& store, ServerOptions options)
    : impl_(std::make_unique<Impl>(store, std::move(options))) {}

Server::~Server() { stop(); }

void Server::start() {
  impl_->load_tls();
  impl_->listen();
  impl_->accept();
  for (int i = 0; i < std::max(1, impl_->options.io_threads); ++i)
    impl_->threads.emplace_back([this] { impl_->ioc.run(); });
  spdlog::info("event=listening host={} port={} tls={}", impl_->options.host,
               impl_->bound_port, impl_->use_tls);
}

void Server::stop() {
  if (impl_->threads.empty()) return;
  asio::post(impl_->ioc, [this] {
    boost::system::error_code ignored;
    impl_->acceptor.close(ignored);
  });
  impl_->ioc.stop();
  for (auto& t : impl_->threads) t.join();
  impl_->threads.clear();
  impl_->workers.join();
  impl_->feeds.close_all();
}

std::uint16_t Server::port() const { return impl_->bound_port; }
bool Server::tls() const { return impl_->use_tls; }

}  // namespace arscout::ingest
