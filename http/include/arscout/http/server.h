// An HTTP/1.1 server (plain or TLS) with Boost.Beast, for one Service: the
// transport alone. It accepts connections, reads requests within its limits
// (connections per address, header and body sizes and times, bodies per
// token, slow bodies, streams), runs the Service's answers on worker pools,
// parks long-polls and serves WebSocket feeds without holding a thread
// while they wait, and sends large bodies in pieces. What a request means,
// who may make it and what a feed carries are the Service's; the server
// knows nothing of the store. Beast stays in http/src (it compiles slowly).
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "arscout/http/http_types.h"

namespace arscout::http {

// The transport's limits. "Per token" is per value of the Authorization
// header: the server counts, the Service decides what a token is worth.
struct ServerLimits {
  std::string host = "127.0.0.1";
  std::uint16_t port = 8080;  // 0: any free port (see Server::port)
  std::string tls_cert;       // PEM files; both set: HTTPS only
  std::string tls_key;
  std::size_t max_body_bytes = 64u << 20;
  std::size_t max_header_bytes = 16u << 10;
  // A client must send a whole request header within this time (defeats
  // slow-header attacks); the body gets 30 s + 1 s per 64 KiB in all, and
  // min_body_rate below.
  std::chrono::seconds header_timeout{15};
  std::chrono::seconds idle_timeout{60};  // between keep-alive requests
  int io_threads = 2;
  // The Service's answers (store access, image decoding) run here, off the
  // network threads. Long-polls and WebSocket streams hold none while they
  // wait.
  int worker_threads = 32;
  // Request bodies being read at once: at most this many per token (429
  // beyond), and at most this many bytes (by Content-Length) over all
  // connections (503 beyond), each refused from its header, before its body
  // is read: a body is held in memory until its request is answered, and
  // 32 uploads of 60 MB at once took 1.9 GB.
  std::size_t max_bodies_per_token = 2;
  std::size_t max_body_buffer_bytes = 256u << 20;
  // The requests that run long (Service::runs_long) run on this many others.
  int long_worker_threads = 2;
  // Bodies sent in pieces (HttpResponse::body_reader): the bytes read and
  // not yet written, over all connections; one piece is at most 1 MiB.
  std::size_t max_send_buffer_bytes = 32u << 20;
  // Open long-polls and WebSocket streams, in all and per token (429
  // beyond either); 0: no cap.
  std::size_t max_streams = 1000;
  std::size_t max_streams_per_token = 100;
  // Open connections, in all and per client address: one past either cap
  // is answered 503 and closed at once. The total is also kept under the
  // process's open-file limit. 0: no cap.
  std::size_t max_connections = 4000;
  std::size_t max_connections_per_address = 200;
  // A request body must arrive at this many bytes per second or more,
  // over every 10 s (408 and closed otherwise); 0: no minimum.
  std::size_t min_body_rate = 1024;
  // The monitoring paths: answered on a small pool of their own (a monitor
  // never waits behind a crowd of requests), and all a connection past its
  // address's cap may still ask.
  std::vector<std::string> operations_paths = {"/healthz", "/metrics"};
};

// What the server counts, for the Service's /metrics. Called from any
// thread.
class ServerMetrics {
 public:
  virtual ~ServerMetrics() = default;
  virtual void connection_opened() = 0;
  virtual void connection_closed() = 0;
  // Parked long-polls and WebSocket streams.
  virtual void stream_opened() = 0;
  virtual void stream_closed() = 0;
  // A client turned away by a cap: "connections", "streams", "slow_body"
  // or "bodies".
  virtual void refused(const std::string& reason) = 0;
  // A request answered `status` by the server itself, from its header
  // (too large, malformed, past the operations-only cap).
  virtual void rejected(int status) = 0;
};

// One WebSocket subscriber's messages, read in order. Each call runs on a
// worker (it may read a store and block) and must not throw; the server
// never runs two next() of one feed at once, but still_allowed() may run
// beside one.
class EventFeed {
 public:
  virtual ~EventFeed() = default;

  struct Batch {
    std::vector<std::string> texts;  // text frames to send, in order
    // Where nothing more was read: wait until Service::notify_after this
    // position before asking again.
    std::int64_t wait_after = 0;
    bool full = false;    // more may follow at once: ask again now
    bool failed = false;  // nothing read: the server asks again in 1 s
  };
  // The next messages after those returned so far.
  virtual Batch next() = 0;
  // Whether the subscriber may still read (its token is neither revoked
  // nor expired); asked every second, and the stream closes once false.
  virtual bool still_allowed() = 0;
  // The token its streams are counted by (max_streams_per_token).
  virtual std::string stream_key() const = 0;
};

// What the server serves. handle, refuse_before_body and subscribe run on
// worker threads and may block (a store); runs_long, notify_after, cancel
// and metrics are called from the network threads and must not.
class Service {
 public:
  virtual ~Service() = default;

  // Answers one request; never throws. A request with may_park may be
  // answered with HttpResponse::park_after instead: the server then waits,
  // holding no thread, until notify_after(park_after) wakes it or the
  // request's ?wait= seconds pass, and asks again with the seconds left.
  virtual HttpResponse handle(const HttpRequest& request) = 0;
  // A request known by its header only (method, target, path, headers,
  // remote; no body): the answer it gets whatever its body says, or
  // nullopt to read the body. Lets the server refuse before reading a body
  // (and before "100 Continue").
  virtual std::optional<HttpResponse> refuse_before_body(
      const HttpRequest& head) = 0;
  // Whether the request takes seconds: it then runs on the small pool for
  // long requests, at low priority. A lookup, not a store read.
  virtual bool runs_long(const HttpRequest& request) const = 0;
  // A WebSocket upgrade (path and query set when the target parses): its
  // feed, or the response to send instead of upgrading. Never throws.
  virtual std::variant<std::unique_ptr<EventFeed>, HttpResponse> subscribe(
      const HttpRequest& request) = 0;

  // Calls `wake` once, when the Service's position (a change log's last
  // seq) is past `after`: at once on the caller's thread, or later on a
  // thread `wake` must not block. Returns an id for cancel().
  virtual std::uint64_t notify_after(std::int64_t after,
                                     std::function<void()> wake) = 0;
  // Forgets a wake-up; no effect when it ran already.
  virtual void cancel(std::uint64_t id) = 0;

  virtual ServerMetrics& metrics() = 0;
};

class Server {
 public:
  // `service` must outlive the server: connections still open when it is
  // destroyed cancel their wake-ups with it.
  Server(ServerLimits limits, Service& service);
  ~Server();  // stops
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  // Binds, listens and starts serving on background threads. Throws
  // std::runtime_error when the address cannot be bound or TLS files load.
  void start();
  // Stops accepting, stops the network threads and joins the pools; no
  // Service call starts after it returns. Open connections close when the
  // server is destroyed.
  void stop();
  std::uint16_t port() const;
  bool tls() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace arscout::http
