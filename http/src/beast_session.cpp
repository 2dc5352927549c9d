// One connection's HTTP/1.1 session, plain or over TLS, with its limits
// and timeouts, parked long-polls and WebSocket subscriptions: the part of
// the server that instantiates Beast's templates (twice, once per stream
// kind), in its own unit so that it and the listener (beast_server.cpp)
// compile side by side. Requests are answered by the Service on a worker
// pool.
#include "beast_session.h"

#include <spdlog/spdlog.h>
#include <boost/asio.hpp>
#include <boost/asio/ssl.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/ssl.hpp>
#include <boost/beast/websocket.hpp>
#include <boost/beast/websocket/ssl.hpp>
#include <deque>
#include <memory>
#include <optional>
#include <variant>

#include "arscout/http/body_rate.h"
#include "arscout/util/process.h"
#include "beast_request.h"

namespace arscout::http {
namespace {

namespace asio = boost::asio;
namespace beast = boost::beast;
// Inside this file `http` is Beast's; arscout::http's own names (HttpRequest,
// parse_target, KeyedLimit, ...) are found unqualified.
namespace http = beast::http;
namespace websocket = beast::websocket;
namespace ssl = asio::ssl;
using tcp = asio::ip::tcp;

using Slot = KeyedLimit::Slot;

HttpResponse too_many_streams(const KeyedLimit& streams) {
  HttpResponse r = HttpResponse::error(
      429, "too_many_streams",
      "too many open long-polls and WebSocket streams (at most " +
          std::to_string(streams.per_key_cap()) + " per token, " +
          std::to_string(streams.total_cap()) +
          " in all); close one or poll less often");
  r.headers.emplace_back("Retry-After", "5");
  return r;
}

// The status line and headers every answer gets, whatever its body.
template <typename Body>
void set_head(http::response<Body>& out, const HttpResponse& r,
              bool keep_alive) {
  out.set(http::field::server, "arscout/0.1");
  out.set(http::field::content_type, r.content_type);
  out.set("X-Content-Type-Options", "nosniff");
  for (auto& [k, v] : r.headers) out.set(k, v);
  out.keep_alive(keep_alive);
}

http::response<http::string_body> to_beast(HttpResponse&& r, unsigned version,
                                           bool keep_alive) {
  http::response<http::string_body> out{static_cast<http::status>(r.status),
                                        version};
  set_head(out, r, keep_alive);
  out.body() = std::move(r.body);
  out.prepare_payload();
  return out;
}

// The threads of the long routes' pool and of the pieces of streamed
// bodies run at nice 10, set once each.
void lower_priority_once() {
  thread_local bool lowered = false;
  if (lowered) return;
  lowered = true;
  util::set_thread_nice(10);
}

// One of the operations paths (/healthz, /metrics), with or without a
// query: what a connection past its address's cap may still ask.
bool is_operations(const ServerLimits& limits, std::string_view target) {
  const std::string_view path = target.substr(0, target.find('?'));
  for (const std::string& p : limits.operations_paths)
    if (path == p) return true;
  return false;
}

// "/healthz and /metrics", for the refusal that says what is still served.
std::string operations_list(const ServerLimits& limits) {
  std::string out;
  for (const std::string& p : limits.operations_paths)
    out += (out.empty() ? "" : " and ") + p;
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
  SubscribeSession(Stream&& stream, SessionContext shared,
                   std::optional<Slot> connection, Slot stream_slot)
      : ws_(std::move(stream)),
        shared_(shared),
        connection_(std::move(connection)),
        stream_slot_(std::move(stream_slot)) {
    shared_.service.metrics().connection_opened();
    shared_.service.metrics().stream_opened();
  }
  ~SubscribeSession() {
    shared_.service.cancel(watch_id_);
    shared_.service.metrics().stream_closed();
    shared_.service.metrics().connection_closed();
  }

  void run(http::request<http::string_body> upgrade,
           std::unique_ptr<EventFeed> feed) {
    tcp_of(beast::get_lowest_layer(ws_)).expires_never();
    ws_.set_option(
        websocket::stream_base::timeout::suggested(beast::role_type::server));
    // A subscriber sends nothing the server reads: a frame past this is
    // refused from its header (Beast's default let each stream buffer
    // 16 MiB, kept while it stayed open).
    ws_.read_message_max(kMaxIncoming);
    feed_ = std::move(feed);
    auto self = this->shared_from_this();
    ws_.async_accept(upgrade, [self](beast::error_code ec) {
      if (ec) return;
      self->fetch();
      self->read_loop();
      self->recheck_token();
    });
  }

 private:
  static constexpr std::size_t kMaxIncoming = 4096;
  // More is read from the feed only while fewer messages wait to be sent: a
  // slow client gets its changes later, and holds no more memory.
  static constexpr std::size_t kRefill = 1000;

  using Batch = EventFeed::Batch;

  // Reads the next batch on a worker and hands it to the session's strand;
  // between batches the session waits on Service::notify_after, holding no
  // thread.
  void fetch() {
    if (fetching_ || closed_) return;
    if (queue_.size() >= kRefill) {
      fetch_when_drained_ = true;
      return;
    }
    fetching_ = true;
    auto self = this->shared_from_this();
    asio::post(shared_.workers, [self] {
      Batch batch = self->feed_->next();
      asio::post(self->ws_.get_executor(),
                 [self, batch = std::move(batch)]() mutable {
                   self->on_batch(std::move(batch));
                 });
    });
  }

  void on_batch(Batch batch) {
    fetching_ = false;
    if (closed_) return;
    if (batch.failed) return retry_later();
    for (std::string& text : batch.texts) enqueue(std::move(text));
    if (batch.full) return fetch();
    std::weak_ptr<SubscribeSession> weak = this->shared_from_this();
    watch_id_ = shared_.service.notify_after(batch.wait_after, [weak] {
      if (auto self = weak.lock())
        asio::post(self->ws_.get_executor(), [self] { self->fetch(); });
    });
  }

  // The feed could not read (its store failed): ask it again shortly.
  void retry_later() {
    retry_.expires_after(std::chrono::seconds(1));
    retry_.async_wait([self = this->shared_from_this()](beast::error_code ec) {
      if (!ec) self->fetch();
    });
  }

  // Every second the feed is asked whether its subscriber may still read
  // (on a worker: it looks the token up); once not, the stream closes.
  void recheck_token() {
    recheck_.expires_after(std::chrono::seconds(1));
    recheck_.async_wait(
        [self = this->shared_from_this()](beast::error_code ec) {
          if (ec) return;  // cancelled: the stream ended
          asio::post(self->shared_.workers, [self] {
            const bool valid = self->feed_->still_allowed();
            asio::post(self->ws_.get_executor(), [self, valid] {
              if (valid) return self->recheck_token();
              self->ws_.async_close(
                  websocket::close_reason(websocket::close_code::policy_error,
                                          "the token was revoked or expired"),
                  [self](beast::error_code) {});
            });
          });
        });
  }

  // The client sends nothing we need; reading notices when it goes away.
  void read_loop() {
    auto self = this->shared_from_this();
    ws_.async_read(incoming_, [self](beast::error_code ec, std::size_t) {
      if (ec) return self->end();
      self->incoming_.consume(self->incoming_.size());
      self->read_loop();
    });
  }

  // Closed: nothing pending keeps the session, which ends with its last
  // owner.
  void end() {
    closed_ = true;
    recheck_.cancel();
    retry_.cancel();
    shared_.service.cancel(watch_id_);
  }

  void enqueue(std::string text) {
    queue_.push_back(std::move(text));
    if (queue_.size() == 1) write_next();
  }

  void write_next() {
    ws_.text(true);
    auto self = this->shared_from_this();
    ws_.async_write(asio::buffer(queue_.front()), [self](beast::error_code ec,
                                                         std::size_t) {
      if (ec) return;
      self->queue_.pop_front();
      if (!self->queue_.empty()) self->write_next();
      if (self->fetch_when_drained_ && self->queue_.size() < kRefill) {
        self->fetch_when_drained_ = false;
        self->fetch();
      }
    });
  }

  websocket::stream<Stream> ws_;
  SessionContext shared_;
  std::optional<Slot> connection_;
  Slot stream_slot_;
  std::unique_ptr<EventFeed> feed_;
  bool fetching_ = false;
  bool fetch_when_drained_ = false;
  bool closed_ = false;
  std::uint64_t watch_id_ = 0;
  asio::steady_timer recheck_{ws_.get_executor()};
  asio::steady_timer retry_{ws_.get_executor()};
  beast::flat_buffer incoming_{kMaxIncoming};
  std::deque<std::string> queue_;
};

// ---------------------------------------------------------------- HTTP

template <typename Stream>
class HttpSession : public std::enable_shared_from_this<HttpSession<Stream>> {
 public:
  HttpSession(Stream&& stream, SessionContext shared,
              std::optional<Slot> connection, bool operations_only)
      : stream_(std::move(stream)),
        shared_(shared),
        connection_(std::move(connection)),
        operations_only_(operations_only),
        body_rate_(shared.limits.min_body_rate) {
    shared_.service.metrics().connection_opened();
    // Beast reads at most the buffer's free capacity (512 bytes minimum),
    // and the body parser empties it after each read: without room here a
    // 3 MB upload takes ~6,000 reads.
    buffer_.reserve(kReadChunk);
  }
  ~HttpSession() {
    shared_.service.cancel(watch_id_);
    release_stream();
    shared_.service.metrics().connection_closed();
  }

  void run() {
    const std::chrono::seconds first = operations_only_
                                           ? std::chrono::seconds(2)
                                           : shared_.limits.header_timeout;
    if constexpr (std::is_same_v<Stream, beast::tcp_stream>) {
      read_header(first);
    } else {
      tcp_of(stream_).expires_after(first);
      stream_.async_handshake(
          ssl::stream_base::server,
          [self = this->shared_from_this(), first](beast::error_code ec) {
            if (!ec) self->read_header(first);
          });
    }
  }

 private:
  static constexpr std::size_t kReadChunk = 64 * 1024;
  // One chunk of the store's blobs (db keeps them in 1 MiB rows): a piece
  // is one row read, not four reads of the same row.
  static constexpr std::int64_t kSendPiece = 1 << 20;

  void read_header(std::chrono::seconds timeout) {
    parser_.emplace();
    limit_request_parser(*parser_, shared_.limits);
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
                        std::to_string(shared_.limits.max_header_bytes) +
                        " bytes");
    if (ec == http::error::body_limit) return reject_too_large();
    if (ec) return;  // closed, timed out or garbage: drop the connection
    const auto target = parser_->get().target();
    if (operations_only_ &&
        !is_operations(shared_.limits,
                       std::string_view(target.data(), target.size()))) {
      shared_.service.metrics().refused("connections");
      return reject(
          503, "unavailable",
          "too many connections from this address (at most " +
              std::to_string(shared_.limits.max_connections_per_address) +
              "); " + operations_list(shared_.limits) + " are still answered");
    }
    if (std::string problem = transfer_encoding_problem(parser_->get());
        !problem.empty())
      return reject(400, "bad_request", problem);
    auto length = parser_->content_length();
    if (length && *length > shared_.limits.max_body_bytes)
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
    head.remote = remote_address();
    auto parsed = parse_target(head.target);
    if (!parsed) return continue_body();  // on_body answers the bad URL
    head.path = std::move(parsed->path);
    auto self = this->shared_from_this();
    asio::post(shared_.workers, [self, head = std::move(head)] {
      auto refusal = self->shared_.service.refuse_before_body(head);
      asio::post(self->stream_.get_executor(),
                 [self, refusal = std::move(refusal)]() mutable {
                   if (refusal) return self->refuse(std::move(*refusal));
                   if (auto full = self->take_body_room())
                     return self->refuse(std::move(*full));
                   self->continue_body();
                 });
    });
  }

  // Room for the body about to be read (SessionContext::bodies and
  // body_budget), held until the request is answered; the refusal when
  // there is none.
  std::optional<HttpResponse> take_body_room() {
    const auto& header = parser_->get();
    auto slot =
        shared_.bodies.acquire(std::string(header[http::field::authorization]));
    if (!slot) {
      shared_.service.metrics().refused("bodies");
      HttpResponse r = HttpResponse::error(
          429, "too_many_bodies",
          "this token is sending " +
              std::to_string(shared_.bodies.per_key_cap()) +
              " request bodies already; send this one when one is answered");
      r.headers.emplace_back("Retry-After", "1");
      return r;
    }
    const auto length =
        parser_->content_length().value_or(shared_.limits.max_body_bytes);
    auto hold = shared_.body_budget.take(static_cast<std::size_t>(length));
    if (!hold) {
      shared_.service.metrics().refused("bodies");
      HttpResponse r = HttpResponse::error(
          503, "unavailable",
          "the server is receiving as many request bodies as it holds; "
          "try again shortly");
      r.headers.emplace_back("Retry-After", "1");
      return r;
    }
    body_slot_.emplace(std::move(*slot));
    body_hold_.emplace(std::move(*hold));
    return std::nullopt;
  }

  void continue_body() {
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

  // The body in pieces, each within the stall time, all within the body's
  // deadline (set by continue_body), at min_body_rate or faster.
  void read_body() {
    if (parser_->is_done()) return on_body({});  // no body, or read already
    const auto now = std::chrono::steady_clock::now();
    body_deadline_ = now + body_time();
    body_rate_.start(now);
    read_body_some();
  }

  std::chrono::seconds body_time() {
    auto length = parser_->content_length();
    return std::chrono::seconds(30) +
           std::chrono::seconds(length.value_or(0) / (64 * 1024));
  }

  void read_body_some() {
    constexpr auto kStall = std::chrono::seconds(10);
    const auto left = body_deadline_ - std::chrono::steady_clock::now();
    tcp_of(stream_).expires_after(
        std::min<std::chrono::steady_clock::duration>(left, kStall));
    http::async_read_some(stream_, buffer_, *parser_,
                          [self = this->shared_from_this()](
                              beast::error_code ec, std::size_t bytes) {
                            self->on_body_some(ec, bytes);
                          });
  }

  void on_body_some(beast::error_code ec, std::size_t bytes) {
    if (ec || parser_->is_done()) return on_body(ec);
    if (!body_rate_.add(bytes, std::chrono::steady_clock::now())) {
      shared_.service.metrics().refused("slow_body");
      return reject(408, "request_timeout",
                    "the request body arrived slower than " +
                        std::to_string(body_rate_.min_rate()) +
                        " bytes per second");
    }
    read_body_some();
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
    req.may_park = true;
    req.remote = remote_address();
    answer(std::move(req), version, keep_alive && !operations_only_);
  }

  // The Service answers on a worker; a long-poll with nothing to show yet is
  // parked instead (park), and asked again when woken.
  void answer(HttpRequest req, unsigned version, bool keep_alive) {
    auto self = this->shared_from_this();
    const bool long_route = shared_.service.runs_long(req);
    auto& pool = long_route ? shared_.long_workers
                 : is_operations(shared_.limits, req.path)
                     ? shared_.operations_workers
                     : shared_.workers;
    asio::post(pool, [self, req = std::move(req), version, keep_alive,
                      long_route]() mutable {
      // An export's build takes the cores only when the rest of the server
      // leaves them: /healthz and the uploads go first.
      if (long_route) lower_priority_once();
      HttpResponse response = self->shared_.service.handle(req);
      asio::post(self->stream_.get_executor(),
                 [self, req = std::move(req), response = std::move(response),
                  version, keep_alive]() mutable {
                   if (response.park_after)
                     return self->park(std::move(req), *response.park_after,
                                       version, keep_alive);
                   self->release_stream();
                   self->body_slot_.reset();  // the body is answered
                   self->body_hold_.reset();
                   self->send(std::move(response), version, keep_alive,
                              req.method == "HEAD");
                 });
    });
  }

  // A long-poll waits on Service::notify_after and a timer for its `wait`,
  // holding a stream slot but no thread; whichever comes first unparks it.
  void park(HttpRequest req, std::int64_t after, unsigned version,
            bool keep_alive) {
    if (!stream_slot_) {
      stream_slot_ = shared_.streams.acquire(req.header("authorization"));
      if (!stream_slot_) {
        shared_.service.metrics().refused("streams");
        return send(too_many_streams(shared_.streams), version, keep_alive);
      }
      shared_.service.metrics().stream_opened();
      park_deadline_ = std::chrono::steady_clock::now() +
                       std::chrono::seconds(std::stoi(req.query["wait"]));
    }
    parked_.emplace(Parked{std::move(req), version, keep_alive});
    std::weak_ptr<HttpSession> weak = this->shared_from_this();
    watch_id_ = shared_.service.notify_after(after, [weak] {
      if (auto self = weak.lock())
        asio::post(self->stream_.get_executor(), [self] { self->unpark(); });
    });
    park_timer_.expires_at(park_deadline_);
    park_timer_.async_wait(
        [self = this->shared_from_this()](beast::error_code ec) {
          if (!ec) self->unpark();
        });
  }

  void unpark() {
    if (!parked_) return;  // the other wake-up came first
    Parked p = std::move(*parked_);
    parked_.reset();
    shared_.service.cancel(watch_id_);
    park_timer_.cancel();
    const auto left = park_deadline_ - std::chrono::steady_clock::now();
    const auto seconds = std::chrono::ceil<std::chrono::seconds>(left).count();
    p.request.query["wait"] = std::to_string(std::max<long long>(0, seconds));
    answer(std::move(p.request), p.version, p.keep_alive);
  }

  void release_stream() {
    if (!stream_slot_) return;
    stream_slot_.reset();
    shared_.service.metrics().stream_closed();
  }

  // The Service decides on a worker (it may read a store, which may be
  // down: its answer then, not an exception on the network thread), then
  // the session goes on on its own strand. A target that does not parse
  // reaches it with no path.
  void upgrade() {
    auto request =
        std::make_shared<http::request<http::string_body>>(parser_->release());
    HttpRequest req = to_request(http::request<http::string_body>(*request));
    if (auto parsed = parse_target(req.target)) {
      req.path = parsed->path;
      req.query = parsed->query;
    }
    req.remote = remote_address();
    auto self = this->shared_from_this();
    asio::post(shared_.workers, [self, req = std::move(req), request] {
      auto checked = self->shared_.service.subscribe(req);
      asio::post(self->stream_.get_executor(),
                 [self, request, checked = std::move(checked)]() mutable {
                   self->accept_upgrade(std::move(*request),
                                        std::move(checked));
                 });
    });
  }

  void accept_upgrade(
      http::request<http::string_body> request,
      std::variant<std::unique_ptr<EventFeed>, HttpResponse> checked) {
    if (auto* error = std::get_if<HttpResponse>(&checked))
      return send(std::move(*error), request.version(), false);
    auto& feed = std::get<std::unique_ptr<EventFeed>>(checked);
    auto slot = shared_.streams.acquire(feed->stream_key());
    if (!slot) {
      shared_.service.metrics().refused("streams");
      return send(too_many_streams(shared_.streams), request.version(), false);
    }
    auto ws = std::make_shared<SubscribeSession<Stream>>(
        std::move(stream_), shared_, std::move(connection_), std::move(*slot));
    ws->run(std::move(request), std::move(feed));
  }

  void reject_too_large() {
    reject(413, "payload_too_large",
           "the request body is larger than the limit of " +
               std::to_string(shared_.limits.max_body_bytes) + " bytes");
  }

  // Answers without reading the rest of the request, then closes.
  void reject(int status, const std::string& kind, const std::string& message) {
    shared_.service.metrics().rejected(status);
    send(HttpResponse::error(status, kind, message), 11, false);
  }

  // A HEAD request's answer (head_only) is the GET's header alone, with
  // the length the body would have.
  void send(HttpResponse&& response, unsigned version, bool keep_alive,
            bool head_only = false) {
    if (response.body_reader)
      return send_streamed(std::move(response), version, keep_alive, head_only);
    auto message = std::make_shared<http::response<http::string_body>>(
        to_beast(std::move(response), version, keep_alive));
    tcp_of(stream_).expires_after(std::chrono::seconds(60));
    if (head_only) {
      auto serializer =
          std::make_shared<http::response_serializer<http::string_body>>(
              *message);
      return http::async_write_header(
          stream_, *serializer,
          [self = this->shared_from_this(), message, serializer](
              beast::error_code ec, std::size_t) {
            if (!ec) self->after_answer(message->keep_alive());
          });
    }
    http::async_write(stream_, *message,
                      [self = this->shared_from_this(), message](
                          beast::error_code ec, std::size_t) {
                        if (ec) return;
                        if (!message->keep_alive()) return self->close();
                        self->read_header(self->shared_.limits.idle_timeout);
                      });
  }

  // The header, then the body a piece at a time: each piece is read on a
  // worker once the server's budget of bytes in flight has room, written,
  // and only then is the next one read. A slow client holds one piece.
  void send_streamed(HttpResponse&& response, unsigned version, bool keep_alive,
                     bool head_only) {
    auto reader = std::make_shared<HttpResponse::BodyReader>(
        std::move(*response.body_reader));
    auto head = std::make_shared<http::response<http::empty_body>>(
        static_cast<http::status>(response.status), version);
    set_head(*head, response, keep_alive);
    head->content_length(static_cast<std::uint64_t>(reader->size));
    auto serializer =
        std::make_shared<http::response_serializer<http::empty_body>>(*head);
    tcp_of(stream_).expires_after(std::chrono::seconds(60));
    http::async_write_header(
        stream_, *serializer,
        [self = this->shared_from_this(), head, serializer, reader, keep_alive,
         head_only](beast::error_code ec, std::size_t) {
          if (ec) return;
          if (head_only) return self->after_answer(keep_alive);
          self->send_piece(reader, 0, keep_alive);
        });
  }

  void send_piece(std::shared_ptr<HttpResponse::BodyReader> reader,
                  std::int64_t offset, bool keep_alive) {
    if (offset >= reader->size) return after_answer(keep_alive);
    const auto length = static_cast<std::size_t>(
        std::min<std::int64_t>(kSendPiece, reader->size - offset));
    auto hold = shared_.send_budget.take(length);
    auto self = this->shared_from_this();
    if (!hold) {  // the budget is spent: try again shortly
      piece_timer_.expires_after(std::chrono::milliseconds(10));
      return piece_timer_.async_wait(
          [self, reader, offset, keep_alive](beast::error_code ec) {
            if (!ec) self->send_piece(reader, offset, keep_alive);
          });
    }
    auto piece = std::make_shared<Piece>(Piece{{}, std::move(*hold)});
    asio::post(shared_.piece_workers, [self, reader, offset, length, keep_alive,
                                       piece] {
      lower_priority_once();
      bool read = false;
      try {
        piece->bytes = reader->read(offset, length);
        read = !piece->bytes.empty() && piece->bytes.size() <= length;
      } catch (const std::exception& e) {
        spdlog::warn("event=body_read_failed offset={} error=\"{}\"", offset,
                     e.what());
      }
      asio::post(self->stream_.get_executor(),
                 [self, reader, offset, keep_alive, piece, read] {
                   // Unread, the client sees a short body.
                   if (!read) return self->abort();
                   const auto next =
                       offset + static_cast<std::int64_t>(piece->bytes.size());
                   self->write_piece(reader, next, keep_alive, piece);
                 });
    });
  }

  struct Piece {
    std::string bytes;
    ByteBudget::Hold hold;  // given back once written (or failed)
  };

  void write_piece(std::shared_ptr<HttpResponse::BodyReader> reader,
                   std::int64_t next, bool keep_alive,
                   std::shared_ptr<Piece> piece) {
    tcp_of(stream_).expires_after(std::chrono::seconds(60));
    asio::async_write(
        stream_, asio::buffer(piece->bytes),
        [self = this->shared_from_this(), reader, next, keep_alive, piece](
            beast::error_code ec, std::size_t) mutable {
          piece.reset();
          if (!ec) self->send_piece(reader, next, keep_alive);
        });
  }

  // The answer is written: the next request, or the close.
  void after_answer(bool keep_alive) {
    if (!keep_alive) return close();
    read_header(shared_.limits.idle_timeout);
  }

  void abort() {
    beast::error_code ignored;
    socket_of(stream_).shutdown(tcp::socket::shutdown_both, ignored);
    socket_of(stream_).close(ignored);
  }

  // The client's address ("" once the socket has gone): what failed
  // authentications and the access log are counted by.
  std::string remote_address() {
    beast::error_code ec;
    const auto peer = socket_of(stream_).remote_endpoint(ec);
    return ec ? std::string() : peer.address().to_string();
  }

  void close() {
    beast::error_code ignored;
    socket_of(stream_).shutdown(tcp::socket::shutdown_send, ignored);
  }

  struct Parked {
    HttpRequest request;
    unsigned version;
    bool keep_alive;
  };

  Stream stream_;
  SessionContext shared_;
  std::optional<Slot> connection_;
  const bool operations_only_;
  // Room taken for the request body being read (take_body_room).
  std::optional<Slot> body_slot_;
  std::optional<ByteBudget::Hold> body_hold_;
  beast::flat_buffer buffer_;
  std::optional<BeastRequestParser> parser_;
  BodyRate body_rate_;
  std::chrono::steady_clock::time_point body_deadline_;
  // A parked long-poll: its request, stream slot, deadline and wake-ups.
  std::optional<Parked> parked_;
  std::optional<Slot> stream_slot_;
  std::chrono::steady_clock::time_point park_deadline_;
  std::uint64_t watch_id_ = 0;
  asio::steady_timer park_timer_{stream_.get_executor()};
  asio::steady_timer piece_timer_{stream_.get_executor()};
};

}  // namespace

void serve_connection(tcp::socket socket, ssl::context* tls,
                      const SessionContext& context,
                      std::optional<KeyedLimit::Slot> connection,
                      bool operations_only) {
  if (tls) {
    std::make_shared<HttpSession<beast::ssl_stream<beast::tcp_stream>>>(
        beast::ssl_stream<beast::tcp_stream>(
            beast::tcp_stream(std::move(socket)), *tls),
        context, std::move(connection), operations_only)
        ->run();
  } else {
    std::make_shared<HttpSession<beast::tcp_stream>>(
        beast::tcp_stream(std::move(socket)), context, std::move(connection),
        operations_only)
        ->run();
  }
}

}  // namespace arscout::http
