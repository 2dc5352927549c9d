// The arscout HTTP(S) server: the v1 API of docs/api.md over one store,
// served by http::Server (arscout/http/server.h) with the API as its
// Service.
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
#include "arscout/http/server.h"
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
// runs on the server's worker pool, and a db::StoreError or util::Error it
// throws is answered with error_response (store_errors.h).
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

// The transport's limits (http::ServerLimits: address, TLS, sizes, times,
// threads and caps), and the API's own options below.
struct ServerOptions : http::ServerLimits {
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
  // Stops accepting and joins the threads (the server's, the change
  // watch's and the store probe's); open connections close with the
  // server.
  void stop();
  std::uint16_t port() const;
  bool tls() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace arscout::ingest
