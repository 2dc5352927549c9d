// The v1 API (docs/api.md) as a function from request to response. Knows
// nothing of sockets; http::Server feeds it (server.cpp).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "arscout/db/store.h"
#include "arscout/ingest/auth.h"
#include "arscout/ingest/server.h"
#include "client_limits.h"
#include "metrics.h"
#include "store_health.h"

namespace arscout::ingest {

class Api {
 public:
  // `routes` go before ingest's own /v1 routes (ServerOptions::routes).
  Api(db::Store& store, Metrics& metrics, std::vector<ApiRoute> routes = {},
      std::vector<http::StaticMount> static_mounts = {});
  // From ServerOptions: serve_api, extra_metrics, health_details.
  Api(db::Store& store, Metrics& metrics, const ServerOptions& options);
  // The route table's handlers hold `this`.
  Api(const Api&) = delete;
  Api& operator=(const Api&) = delete;

  // Answers one request; never throws. Records it in the metrics.
  HttpResponse handle(const HttpRequest& request);

  // A WebSocket /v1/subscribe request, checked: where to start, or the
  // error response to send instead of upgrading.
  struct Subscribe {
    std::int64_t since = 0;
    std::string pattern = "/**";
    Principal who;  // the feed carries only what `who` may read
    // How it authenticated ("Bearer ..."): checked again every second, so
    // a revoked or expired token's stream ends.
    std::string authorization;
  };
  std::variant<Subscribe, HttpResponse> check_subscribe(
      const HttpRequest& request);

  // A request known by its header only (method, path, headers; no body):
  // the 401 or 403 it will get whatever its body says, so the server can
  // answer before reading a body (and before "100 Continue"), or nullopt
  // when the body is needed to decide. Touches the store (the token).
  std::optional<HttpResponse> refuse_before_body(const HttpRequest& head);

  // Whether the request's route runs long (ApiRoute::runs_long).
  bool runs_long(const HttpRequest& request) const;

  // The metrics label of a request's route ("GET /v1/docs/*", "other").
  std::string route_template(const std::string& method,
                             const std::string& path) const;

  db::Store& store() { return store_; }
  // What /healthz reports; the server starts its thread.
  StoreHealth& store_health() { return store_health_; }
  Metrics& metrics() { return metrics_; }

 private:
  HttpResponse dispatch(const HttpRequest& request, std::string* route);
  std::vector<ApiRoute> builtin_routes(std::vector<ApiRoute> added);
  HttpResponse render_metrics() const;

  // The token's principal, or the 401 (or, past the address's failures,
  // the 429) to answer instead; a failure counts against the address.
  std::variant<Principal, HttpResponse> authenticate_client(
      const std::string& authorization, const std::string& remote);

  db::Store& store_;
  Metrics& metrics_;
  std::unique_ptr<ClientLimits> limits_ = std::make_unique<ClientLimits>();
  StoreHealth store_health_{store_};
  std::vector<ApiRoute> routes_;  // /healthz, /metrics, added, ingest's /v1
  std::vector<http::StaticMount> static_mounts_;
  bool serve_api_ = true;
  std::function<std::string()> extra_metrics_;
  std::function<Json()> health_details_;
};

}  // namespace arscout::ingest
