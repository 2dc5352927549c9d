#include "api.h"

#include <chrono>

#include <spdlog/spdlog.h>

#include "api_handlers.h"
#include "arscout/db/path.h"
#include "arscout/util/error.h"
#include "arscout/util/log_value.h"
#include "route_table.h"

namespace arscout::ingest {
namespace {

bool starts_with(const std::string& s, std::string_view prefix) {
  return s.compare(0, prefix.size(), prefix) == 0;
}

HttpResponse method_not_allowed(const std::string& allowed) {
  HttpResponse r = HttpResponse::error(405, "method_not_allowed",
                                       "this resource allows " + allowed);
  r.headers.emplace_back("Allow", allowed);
  return r;
}

HttpResponse forbidden(const std::string& why) {
  return HttpResponse::error(403, "forbidden", why);
}

const char* failure_message(AuthFailure failure) {
  switch (failure) {
    case AuthFailure::kMissing:
      return "an Authorization: Bearer token is required";
    case AuthFailure::kMalformed:
      return "the Authorization header is not \"Bearer \" and a token of at "
             "most 200 characters";
    case AuthFailure::kUnknown:
      return "this server knows no such token";
    case AuthFailure::kRevoked:
      return "the token has been revoked";
    case AuthFailure::kExpired:
      return "the token has expired";
  }
  return "the bearer token is not valid";
}

// A 401 that says what is wrong with the token, by name in "reason" (a
// client tells its user what to do: ask for a new token, sign in again),
// with RFC 6750's WWW-Authenticate.
HttpResponse unauthorized(AuthFailure failure) {
  HttpResponse r =
      HttpResponse::error(401, "unauthorized", failure_message(failure),
                          Json{{"reason", to_string(failure)}});
  r.headers.emplace_back("WWW-Authenticate", failure == AuthFailure::kMissing
                                                 ? "Bearer realm=\"arscout\""
                                                 : "Bearer realm=\"arscout\", "
                                                   "error=\"invalid_token\"");
  return r;
}

// GET /v1/me: who the token is, so that a client can check it at sign-in.
HttpResponse me_route(ApiContext& ctx, const HttpRequest&, const std::string&) {
  return HttpResponse::json(
      200, Json{{"name", ctx.who.name},
                {"role", to_string(ctx.who.role)},
                {"expires", ctx.who.expires.empty() ? Json(nullptr)
                                                    : Json(ctx.who.expires)}});
}

HttpResponse operations_only() {
  return HttpResponse::error(404, "not_found",
                             "only /healthz and /metrics are served here");
}

HttpResponse health(db::Store& store, StoreHealth& probe,
                    const std::function<Json()>& details) {
  const StoreHealth::Reading reading = probe.check();
  if (!reading.ok)
    return HttpResponse::error(503, "unavailable", reading.error);
  Json body{{"status", "ok"},
            {"backend", store.backend()},
            {"last_seq", reading.last_seq}};
  if (details) body.update(details());
  return HttpResponse::json(200, body);
}

// A built-in route's handler: the context, the request, and what the
// pattern's last "*" matched (the document path, the capture or camera id,
// the blob hash).
using Handler = std::function<HttpResponse(ApiContext&, const HttpRequest&,
                                           const std::string& rest)>;

HttpResponse docs_route(ApiContext& ctx, const HttpRequest& req,
                        const std::string& rest) {
  const std::string doc_path = "/" + rest;
  if (!can_read(ctx.who, doc_path))
    return forbidden("only admins may read or write " + doc_path);
  return docs_request(ctx, req, doc_path);
}

// The target as logged: a token sent as ?access_token= (however its name
// was percent-encoded) is replaced by "***", since logs are read by more
// people than tokens should be.
std::string target_for_log(const HttpRequest& request) {
  if (!request.query.count("access_token")) return request.target;
  std::string out = request.path;
  char separator = '?';
  for (const auto& [key, value] : request.query) {
    out += separator + key + "=" + (key == "access_token" ? "***" : value);
    separator = '&';
  }
  return out;
}

// The access log: one line per answered request, at info (quiet by
// default).
void log_access(const HttpRequest& request, int status, double seconds) {
  if (!spdlog::should_log(spdlog::level::info)) return;
  spdlog::info(
      "event=request method={} target={} status={} ms={:.1f} remote={}",
      method_label(request.method),
      util::quoted_log_value(target_for_log(request), 512), status,
      seconds * 1000, request.remote.empty() ? "-" : request.remote);
}

}  // namespace

std::string scoped_id(const Principal& who, const std::string& id) {
  const std::string space = who.name + ".";
  return id.rfind(space, 0) == 0 ? id : space + id;
}

bool can_read(const Principal& who, const std::string& doc_path) {
  return who.role == Role::kAdmin ||
         !(doc_path == "/auth" || starts_with(doc_path, "/auth/"));
}

// Appended, not `"\"" + text + "\""`: that form trips a false -Wrestrict
// in GCC 12 at -O3 (the Release build of the README's main job).
std::string etag_value(std::string_view text) {
  std::string out;
  out.reserve(text.size() + 2);
  out.push_back('"');
  out.append(text);
  out.push_back('"');
  return out;
}

HttpResponse document_response(int status, const db::Document& doc) {
  HttpResponse r = HttpResponse::json(status, to_json(doc));
  r.headers.emplace_back("ETag", etag_value(std::to_string(doc.version)));
  return r;
}

Api::Api(db::Store& store, Metrics& metrics, std::vector<ApiRoute> routes,
         std::vector<http::StaticMount> static_mounts)
    : store_(store),
      metrics_(metrics),
      routes_(builtin_routes(std::move(routes))),
      static_mounts_(std::move(static_mounts)) {}

Api::Api(db::Store& store, Metrics& metrics, const ServerOptions& options)
    : Api(store, metrics, options.routes, options.static_mounts) {
  limits_ = std::make_unique<ClientLimits>(options);
  serve_api_ = options.serve_api;
  extra_metrics_ = options.extra_metrics;
  health_details_ = options.health_details;
}

// The API of docs/api.md, one row per route. The operations come first (no
// token, and served without the API too), then the routes other libraries
// added (so that theirs under /v1/captures/ win), then the v1 API.
std::vector<ApiRoute> Api::builtin_routes(std::vector<ApiRoute> added) {
  const auto row = [this](std::vector<std::string> methods, std::string pattern,
                          std::optional<Role> min_role, std::string forbidden,
                          Handler handler) {
    ApiRoute r;
    r.methods = std::move(methods);
    r.pattern = std::move(pattern);
    r.min_role = min_role;
    r.forbidden = std::move(forbidden);
    r.handle = [this, pattern = r.pattern, handler = std::move(handler)](
                   const HttpRequest& req, const Principal& who) {
      ApiContext ctx{store_, metrics_, who, limits_.get()};
      std::string rest;
      pattern_matches(pattern, req.path, &rest);
      return handler(ctx, req, rest);
    };
    return r;
  };
  using R = const HttpRequest&;
  using S = const std::string&;
  const std::optional<Role> no_token, any = Role::kPlanner;
  std::vector<ApiRoute> routes = {
      row({"GET"}, "/healthz", no_token, "",
          [this](ApiContext&, R, S) {
            return health(store_, store_health_, health_details_);
          }),
      row({"GET"}, "/metrics", no_token, "",
          [this](ApiContext&, R, S) { return render_metrics(); }),
  };
  for (ApiRoute& r : added) routes.push_back(std::move(r));
  std::vector<ApiRoute> v1 = {
      row({"GET", "HEAD"}, "/v1/docs/*", any, "", docs_route),
      row({}, "/v1/docs/*", Role::kAdmin,
          "writing documents needs the admin role", docs_route),
      row({"POST"}, "/v1/captures", Role::kScout,
          "planners may not upload captures",
          [](ApiContext& ctx, R req, S) { return post_capture(ctx, req); }),
      row({"DELETE"}, "/v1/captures/*", any, "", withdraw_capture),
      row({"GET"}, "/v1/blobs/*", any, "", get_blob),
      row({"PUT"}, "/v1/cameras/*", Role::kScout,
          "planners may not change cameras", put_camera),
      row({"GET"}, "/v1/changes", any, "",
          [](ApiContext& ctx, R req, S) { return get_changes(ctx, req); }),
      row({"GET"}, "/v1/sites", any, "",
          [](ApiContext& ctx, R req, S) { return get_sites(ctx, req); }),
      row({"PATCH"}, "/v1/sites/*", any, "", patch_site),
      row({"GET"}, "/v1/me", any, "", me_route),
      row({}, "/v1/subscribe", any, "",
          [](ApiContext&, R, S) {
            return HttpResponse::error(
                400, "bad_request", "/v1/subscribe needs a WebSocket upgrade");
          }),
  };
  for (ApiRoute& r : v1) routes.push_back(std::move(r));
  return routes;
}

HttpResponse Api::render_metrics() const {
  HttpResponse r;
  r.content_type = "text/plain; version=0.0.4";
  r.body = metrics_.render() + (extra_metrics_ ? extra_metrics_() : "");
  return r;
}

bool Api::runs_long(const HttpRequest& request) const {
  const RouteChoice choice = choose_route(routes_, request);
  return choice.route && choice.route->runs_long;
}

std::string Api::route_template(const std::string& method,
                                const std::string& path) const {
  HttpRequest request;
  request.method = method;
  request.path = path;
  return route_label(choose_route(routes_, request), method);
}

std::optional<std::int64_t> int_param(const HttpRequest& req,
                                      const std::string& name,
                                      std::int64_t fallback, std::int64_t min,
                                      std::int64_t max, std::string* error) {
  auto it = req.query.find(name);
  if (it == req.query.end()) return fallback;
  std::size_t used = 0;
  std::int64_t v = 0;
  try {
    v = std::stoll(it->second, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != it->second.size() || v < min || v > max) {
    *error = "query parameter '" + name + "' must be an integer in [" +
             std::to_string(min) + ", " + std::to_string(max) + "]";
    return std::nullopt;
  }
  return v;
}

HttpResponse Api::handle(const HttpRequest& request) {
  auto start = std::chrono::steady_clock::now();
  std::string route = "other";  // dispatch names it once it is known
  HttpResponse response;
  try {
    response = dispatch(request, &route);
  } catch (const db::StoreError& e) {
    response = error_response(e);
  } catch (const util::Error& e) {
    response = error_response(e);
  } catch (const std::exception& e) {
    spdlog::error("event=handler_failed route=\"{}\" error=\"{}\"", route,
                  e.what());
    response = HttpResponse::error(500, "internal", e.what());
  }
  if (response.park_after) return response;  // asked again when woken
  if (response.status == 503 || response.status == 500) metrics_.store_error();
  double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
          .count();
  metrics_.record_request(route, response.status, seconds);
  log_access(request, response.status, seconds);
  return response;
}

std::optional<HttpResponse> Api::refuse_before_body(const HttpRequest& head) {
  const RouteChoice choice = choose_route(routes_, head);
  const bool open = choice.owner && !choice.owner->min_role;
  if (!serve_api_ && !open) return operations_only();
  // Only /v1/ needs a token: an unknown /v1/ path too, so that no client
  // without one gets its body read.
  if (!starts_with(head.path, "/v1/")) return std::nullopt;
  std::variant<Principal, HttpResponse> who;
  try {
    who = authenticate_client(head.header("authorization"), head.remote);
  } catch (const std::exception&) {
    return std::nullopt;  // the store is down: the request gets its 503
  }
  if (auto* refusal = std::get_if<HttpResponse>(&who)) {
    metrics_.record_request(route_label(choice, head.method), refusal->status,
                            0);
    return std::move(*refusal);
  }
  const Principal& principal = std::get<Principal>(who);
  const ApiRoute* route = choice.route;
  if (route && route->min_role &&
      !role_at_least(principal.role, *route->min_role)) {
    metrics_.record_request(route_label(choice, head.method), 403, 0);
    return forbidden(route->forbidden);
  }
  // An upload past its token's rate is refused before its body is read.
  if (head.method == "POST" && head.path == "/v1/captures")
    if (const int wait = limits_->uploads.wait(principal.name); wait > 0) {
      metrics_.refused("uploads");
      return uploads_refused(wait);
    }
  return std::nullopt;
}

std::variant<Principal, HttpResponse> Api::authenticate_client(
    const std::string& authorization, const std::string& remote) {
  if (const int wait = limits_->auth_failures.wait(remote); wait > 0) {
    metrics_.refused("auth_failures");
    return too_many_requests(
        "too_many_failures",
        "too many requests with unknown, revoked or expired tokens from "
        "this address; try again later",
        wait);
  }
  auto checked = check_token(store_, authorization);
  if (auto* who = std::get_if<Principal>(&checked)) return *who;
  // A token that was tried and is unknown, revoked or expired; a request
  // without one is no guess.
  if (!authorization.empty()) limits_->auth_failures.take(remote);
  return unauthorized(std::get<AuthFailure>(checked));
}

HttpResponse Api::dispatch(const HttpRequest& req, std::string* route) {
  const RouteChoice choice = choose_route(routes_, req);
  const bool open = choice.owner && !choice.owner->min_role;
  if (!serve_api_ && !open) return operations_only();
  // The web viewer's files: anything outside /v1/ but the operations.
  if (!open && !starts_with(req.path, "/v1/")) {
    if (auto file = serve_static(static_mounts_, req)) {
      *route = method_label(req.method) + " (static file)";
      return *file;
    }
  }
  if (!choice.owner)
    return HttpResponse::error(404, "not_found", "no route " + req.path);
  *route = route_label(choice, req.method);
  Principal who{Role::kPlanner, ""};  // anonymous, for the open routes
  if (!open) {
    auto token = authenticate_client(req.header("authorization"), req.remote);
    if (auto* refusal = std::get_if<HttpResponse>(&token)) return *refusal;
    who = std::get<Principal>(token);
  }
  if (!choice.route) return method_not_allowed(choice.allowed);
  const std::optional<Role>& least = choice.route->min_role;
  if (least && !role_at_least(who.role, *least))
    return forbidden(choice.route->forbidden);
  return choice.route->handle(req, who);
}

std::variant<Api::Subscribe, HttpResponse> Api::check_subscribe(
    const HttpRequest& req) {
  // Browsers cannot set headers on a WebSocket, so the token may come as
  // ?access_token= here (and only here: elsewhere URLs end up in logs and
  // histories for no reason).
  std::string authorization = req.header("authorization");
  if (auto it = req.query.find("access_token");
      authorization.empty() && it != req.query.end())
    authorization = "Bearer " + it->second;
  auto checked = authenticate_client(authorization, req.remote);
  if (auto* refusal = std::get_if<HttpResponse>(&checked)) {
    if (refusal->status == 401 && authorization.empty())
      return HttpResponse::error(
          401, "unauthorized",
          "a valid Authorization: Bearer token (or ?access_token=) is "
          "required",
          Json{{"reason", to_string(AuthFailure::kMissing)}});
    return *refusal;
  }
  const Principal& who = std::get<Principal>(checked);
  std::string error;
  auto since = int_param(req, "since", 0, 0, INT64_MAX, &error);
  if (!since) return HttpResponse::error(400, "bad_request", error);
  Subscribe s;
  s.since = *since;
  s.who = who;
  s.authorization = authorization;
  if (auto it = req.query.find("pattern"); it != req.query.end())
    s.pattern = it->second;
  try {
    db::validate_pattern(s.pattern);
  } catch (const db::StoreError& e) {
    return error_response(e);
  }
  return s;
}

}  // namespace arscout::ingest
