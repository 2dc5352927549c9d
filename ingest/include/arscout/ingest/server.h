// The arscout HTTP(S) server: the v1 API of docs/api.md over one store.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "arscout/db/store.h"
#include "arscout/http/http_types.h"
#include "arscout/http/static_files.h"
#include "arscout/ingest/auth.h"
#include "arscout/ingest/store_errors.h"

namespace arscout::ingest {

// The HTTP values the routes speak (arscout/http/http_types.h).
using http::HttpRequest;
using http::HttpResponse;
using http::Json;

// A route of the v1 API: ingest's own (api.cpp) and those other libraries
// add (the viewer's overlays, thumbnails and exports), so ingest need not
// link them. A request whose path no route matches is 404. The first
// matching route owns the path, together with the routes right after it
// that have the same pattern (ingest's documents: one route to read, one
// to write); a method none of them takes is 405 with Allow. A request
// without a valid token is 401, a role below the route's 403; the handler
// runs on the handler pool, and a db::StoreError or util::Error it throws
// is answered with error_response (store_errors.h).
struct ApiRoute {
  ApiRoute() = default;
  // A route found by `matches` alone, for any method and any valid token.
  ApiRoute(
      std::string name, std::function<bool(const HttpRequest&)> matches,
      std::function<HttpResponse(const HttpRequest&, const Principal&)> handle)
      : name(std::move(name)),
        matches(std::move(matches)),
        handle(std::move(handle)) {}

  // For metrics, e.g. "GET /v1/sites/*/export"; empty: the request's method
  // and the pattern, "PUT /v1/cameras/*".
  std::string name;
  // The methods it answers; empty: any (the handler answers 405 itself).
  std::vector<std::string> methods;
  // The path: literal segments, "*" for one non-empty segment, and a last
  // "*" for the rest of the path, '/' included, even none:
  // "/v1/blobs/*" matches "/v1/blobs/" and "/v1/blobs/a/b".
  std::string pattern;
  // Decides instead where `pattern` is empty.
  std::function<bool(const HttpRequest&)> matches;
  // The least role that may call it (planner < scout < admin), or nullopt
  // for no token at all (only /healthz and /metrics, which then get an
  // anonymous planner as principal).
  std::optional<Role> min_role = Role::kPlanner;
  std::string forbidden;  // the 403's message for a lesser role
  std::function<HttpResponse(const HttpRequest&, const Principal&)> handle;
  // Takes seconds (an export that builds a file): run on the server's small
  // pool for long requests, so that many of them wait for each other and
  // not every other request for them.
  bool runs_long = false;
};

struct ServerOptions {
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
  // Handlers (store access, image decoding) run here, off the network
  // threads. Long-polls and WebSocket streams hold none while they wait.
  int worker_threads = 32;
  // Request bodies being read at once: at most this many per token (429
  // beyond), and at most this many bytes (by Content-Length) over all
  // connections (503 beyond), each refused from its header, before its body
  // is read: a body is held in memory until its request is answered, and
  // 32 uploads of 60 MB at once took 1.9 GB.
  std::size_t max_bodies_per_token = 2;
  std::size_t max_body_buffer_bytes = 256u << 20;
  // The routes that run long (ApiRoute::runs_long) run on this many others.
  int long_worker_threads = 2;
  // Bodies sent in pieces (blobs, exports): the bytes read and not yet
  // written, over all connections; one piece is at most 1 MiB.
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
  // Per token: uploads (POST /v1/captures), at most upload_burst at once
  // and uploads_per_hour on average; and captures in new places (a fix
  // farther than new_place_m from every site and from the token's other
  // recent new places: each may found a site), at most new_place_burst at
  // once and new_places_per_hour on average. Per client address: failed
  // authentications (an unknown, revoked or expired token), at most
  // auth_failure_burst at once and auth_failures_per_hour on average; past
  // that every request from the address that needs a token is refused
  // until it may try again. Past any limit: 429 with Retry-After.
  // 0 an hour: no limit of that kind.
  double uploads_per_hour = 3600;
  double upload_burst = 300;
  double new_places_per_hour = 20;
  double new_place_burst = 20;
  double new_place_m = 500;
  double auth_failures_per_hour = 3600;
  double auth_failure_burst = 30;
  // Checked in order, before the built-in /v1 routes (a viewer route under
  // /v1/captures/ wins over DELETE /v1/captures/{id}).
  std::vector<ApiRoute> routes;
  // The longest matching prefix wins; /v1/, /healthz and /metrics never
  // reach them.
  std::vector<http::StaticMount> static_mounts;
  // false: /healthz and /metrics only (every other path 404), as
  // `arscout engine --listen` serves them.
  bool serve_api = true;
  // Appended to /metrics (another component's, e.g. the engine worker's),
  // and merged into /healthz's JSON (e.g. {"engine": {...}}).
  std::function<std::string()> extra_metrics;
  std::function<Json()> health_details;
};

class Server {
 public:
  Server(db::Store& store, ServerOptions options);
  ~Server();  // stops
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  // Binds, listens and starts serving on background threads. Throws
  // std::runtime_error when the address cannot be bound or TLS files load.
  void start();
  // Stops accepting, closes connections and joins the threads.
  void stop();
  std::uint16_t port() const;
  bool tls() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace arscout::ingest
