#include "api.h"

#include <chrono>

#include <spdlog/spdlog.h>

#include "api_handlers.h"
#include "arscout/db/path.h"
#include "arscout/util/log_value.h"

namespace arscout::ingest {
namespace {

constexpr std::string_view kDocs = "/v1/docs";
constexpr std::string_view kCaptures = "/v1/captures";
constexpr std::string_view kBlobs = "/v1/blobs/";
constexpr std::string_view kCameras = "/v1/cameras/";

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

bool may_write_docs(const Principal& who) { return who.role == Role::kAdmin; }

HttpResponse health(db::Store& store, const std::function<Json()>& details) {
  try {
    Json body{{"status", "ok"},
              {"backend", store.backend()},
              {"last_seq", store.last_seq()}};
    if (details) body.update(details());
    return HttpResponse::json(200, body);
  } catch (const db::StoreError& e) {
    return HttpResponse::error(503, "unavailable", e.what());
  }
}

}  // namespace

bool can_read(const Principal& who, const std::string& doc_path) {
  return who.role == Role::kAdmin ||
         !(doc_path == "/auth" || starts_with(doc_path, "/auth/"));
}

// A method as a metrics label: one of a fixed set, so that a client cannot
// grow /metrics by inventing methods (any token is a valid HTTP method).
std::string method_label(const std::string& method) {
  for (const char* known :
       {"GET", "HEAD", "POST", "PUT", "PATCH", "DELETE", "OPTIONS"})
    if (method == known) return method;
  return "OTHER";
}

std::string route_template(const std::string& verb, const std::string& path) {
  const std::string method = method_label(verb);
  if (starts_with(path, kDocs)) return method + " /v1/docs/*";
  if (path == kCaptures) return method + " /v1/captures";
  if (starts_with(path, kCaptures)) return method + " /v1/captures/*";
  if (starts_with(path, kBlobs)) return method + " /v1/blobs/*";
  if (starts_with(path, kCameras)) return method + " /v1/cameras/*";
  for (const char* fixed :
       {"/v1/changes", "/v1/subscribe", "/v1/sites", "/healthz", "/metrics"})
    if (path == fixed) return method + " " + fixed;
  return "other";
}

namespace {

// The access log: one line per answered request, at info (quiet by
// default).
void log_access(const HttpRequest& request, int status, double seconds) {
  if (!spdlog::should_log(spdlog::level::info)) return;
  spdlog::info(
      "event=request method={} target={} status={} ms={:.1f} remote={}",
      method_label(request.method), util::quoted_log_value(request.target, 512),
      status, seconds * 1000, request.remote.empty() ? "-" : request.remote);
}

}  // namespace

HttpResponse error_for(const db::StoreError& e) {
  using db::ErrorCode;
  switch (e.code()) {
    case ErrorCode::kConflict: {
      Json extra = Json::object();
      if (auto* c = dynamic_cast<const db::ConflictError*>(&e))
        extra["current_version"] = c->current_version();
      return HttpResponse::error(409, "conflict", e.what(), extra);
    }
    case ErrorCode::kNotFound:
    case ErrorCode::kUnknownBlob:
      return HttpResponse::error(404, db::to_string(e.code()), e.what());
    case ErrorCode::kTooLarge:
      return HttpResponse::error(413, "too_large", e.what());
    case ErrorCode::kInvalidDocument:
      return HttpResponse::error(422, "invalid_document", e.what());
    case ErrorCode::kUnavailable:
      return HttpResponse::error(503, "unavailable", e.what());
    case ErrorCode::kInternal:
      return HttpResponse::error(500, "internal", e.what());
    default:
      return HttpResponse::error(400, db::to_string(e.code()), e.what());
  }
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

std::optional<Json> parse_json_body(const std::string& text,
                                    std::string* error) {
  // Copying and serialising a JSON value recurse once per level of nesting,
  // so some ten thousand '[' would overflow a handler thread's stack:
  // deeper bodies are refused while they are parsed.
  constexpr int kMaxDepth = 512;
  struct TooDeep {};
  auto limit_depth = [](int depth, Json::parse_event_t event, Json&) {
    if (depth >= kMaxDepth && (event == Json::parse_event_t::object_start ||
                               event == Json::parse_event_t::array_start))
      throw TooDeep{};
    return true;
  };
  try {
    return Json::parse(text, limit_depth);
  } catch (const TooDeep&) {
    *error = "JSON nested deeper than " + std::to_string(kMaxDepth) + " levels";
  } catch (const Json::parse_error& e) {
    *error =
        "malformed JSON at byte " + std::to_string(e.byte) + ": " + e.what();
  } catch (const Json::out_of_range& e) {  // a number beyond a double's range
    *error = std::string("unreadable JSON: ") + e.what();
  }
  return std::nullopt;
}

HttpResponse Api::handle(const HttpRequest& request) {
  auto start = std::chrono::steady_clock::now();
  std::string route = route_template(request.method, request.path);
  HttpResponse response;
  try {
    response = dispatch(request, &route);
  } catch (const db::StoreError& e) {
    response = error_for(e);
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
  const std::string& path = head.path;
  if (!serve_api_ && path != "/healthz" && path != "/metrics")
    return HttpResponse::error(404, "not_found",
                               "only /healthz and /metrics are served here");
  if (!starts_with(path, "/v1/")) return std::nullopt;  // no token needed
  std::optional<Principal> who;
  try {
    who = authenticate(store_, head.header("authorization"));
  } catch (const std::exception&) {
    return std::nullopt;  // the store is down: the request gets its 503
  }
  if (!who) {
    HttpResponse r =
        HttpResponse::error(401, "unauthorized",
                            head.header("authorization").empty()
                                ? "an Authorization: Bearer token is required"
                                : "the bearer token is not valid");
    metrics_.record_request(route_template(head.method, path), 401, 0);
    return r;
  }
  std::string why;
  if (starts_with(path, kDocs) && head.method != "GET" &&
      head.method != "HEAD" && !may_write_docs(*who))
    why = "writing documents needs the admin role";
  else if (who->role == Role::kPlanner &&
           (path == kCaptures || starts_with(path, kCameras)))
    why = "planners may not upload captures or change cameras";
  if (why.empty()) return std::nullopt;
  metrics_.record_request(route_template(head.method, path), 403, 0);
  return forbidden(why);
}

HttpResponse Api::dispatch(const HttpRequest& req, std::string* route) {
  const std::string& path = req.path;
  const std::string& m = req.method;
  if (path == "/healthz")
    return m == "GET" ? health(store_, health_details_)
                      : method_not_allowed("GET");
  if (path == "/metrics") {
    if (m != "GET") return method_not_allowed("GET");
    HttpResponse r;
    r.content_type = "text/plain; version=0.0.4";
    r.body = metrics_.render() + (extra_metrics_ ? extra_metrics_() : "");
    return r;
  }
  if (!serve_api_) {
    *route = "other";
    return HttpResponse::error(404, "not_found",
                               "only /healthz and /metrics are served here");
  }
  if (!starts_with(path, "/v1/")) {
    if (auto file = serve_static(static_mounts_, req)) {
      *route = method_label(m) + " (static file)";
      return *file;
    }
  }
  bool known =
      starts_with(path, std::string(kDocs) + "/") || path == kCaptures ||
      starts_with(path, std::string(kCaptures) + "/") ||
      starts_with(path, kBlobs) || starts_with(path, kCameras) ||
      path == "/v1/changes" || path == "/v1/sites" || path == "/v1/subscribe";
  const ApiRoute* extra = nullptr;
  for (const ApiRoute& r : routes_)
    if (!extra && r.matches(req)) extra = &r;
  if (!known && !extra) {
    *route = "other";
    return HttpResponse::error(404, "not_found", "no route " + path);
  }
  auto who = authenticate(store_, req.header("authorization"));
  if (!who)
    return HttpResponse::error(
        401, "unauthorized",
        req.header("authorization").empty()
            ? "an Authorization: Bearer token is required"
            : "the bearer token is not valid");
  if (extra) {
    *route = extra->name;
    return extra->handle(req, *who);
  }
  ApiContext ctx{store_, metrics_, *who};

  if (starts_with(path, kDocs)) {
    std::string doc_path = path.substr(kDocs.size());
    if (!can_read(*who, doc_path))
      return forbidden("only admins may read or write " + doc_path);
    if (m != "GET" && m != "HEAD" && !may_write_docs(*who))
      return forbidden("writing documents needs the admin role");
    return docs_request(ctx, req, doc_path);
  }
  if (path == kCaptures) {
    if (m != "POST") return method_not_allowed("POST");
    if (who->role == Role::kPlanner)
      return forbidden("planners may not upload captures");
    return post_capture(ctx, req);
  }
  if (starts_with(path, kCaptures)) {
    if (m != "DELETE") return method_not_allowed("DELETE");
    return withdraw_capture(ctx, req, path.substr(kCaptures.size() + 1));
  }
  if (starts_with(path, kBlobs)) {
    if (m != "GET") return method_not_allowed("GET");
    return get_blob(ctx, req, path.substr(kBlobs.size()));
  }
  if (starts_with(path, kCameras)) {
    if (m != "PUT") return method_not_allowed("PUT");
    if (who->role == Role::kPlanner)
      return forbidden("planners may not change cameras");
    return put_camera(ctx, req, path.substr(kCameras.size()));
  }
  if (path == "/v1/changes")
    return m == "GET" ? get_changes(ctx, req) : method_not_allowed("GET");
  if (path == "/v1/sites")
    return m == "GET" ? get_sites(ctx, req) : method_not_allowed("GET");
  return HttpResponse::error(400, "bad_request",
                             "/v1/subscribe needs a WebSocket upgrade");
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
  auto who = authenticate(store_, authorization);
  if (!who)
    return HttpResponse::error(401, "unauthorized",
                               "a valid Authorization: Bearer token (or "
                               "?access_token=) is required");
  std::string error;
  auto since = int_param(req, "since", 0, 0, INT64_MAX, &error);
  if (!since) return HttpResponse::error(400, "bad_request", error);
  Subscribe s;
  s.since = *since;
  s.who = *who;
  s.authorization = authorization;
  if (auto it = req.query.find("pattern"); it != req.query.end())
    s.pattern = it->second;
  try {
    db::validate_pattern(s.pattern);
  } catch (const db::StoreError& e) {
    return error_for(e);
  }
  return s;
}

}  // namespace arscout::ingest
