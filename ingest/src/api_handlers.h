// The API's handlers, one file per resource. Each gets the authenticated
// principal; dispatch (api.cpp, from its route table) has already checked
// the route, the method and the least role.
#pragma once

#include <string>
#include <string_view>

#include "arscout/db/store.h"
#include "arscout/http/json_body.h"
#include "arscout/ingest/auth.h"
#include "arscout/ingest/server.h"
#include "client_limits.h"
#include "metrics.h"

namespace arscout::ingest {

struct ApiContext {
  db::Store& store;
  Metrics& metrics;
  const Principal& who;
  // The server's per-client limits; null where there are none (a session
  // replayed by an operator, the fuzz targets).
  ClientLimits* limits = nullptr;
};

// api_captures.cpp
HttpResponse post_capture(ApiContext& ctx, const HttpRequest& req);
HttpResponse withdraw_capture(ApiContext& ctx, const HttpRequest& req,
                              const std::string& id);
// api_docs.cpp; `path` is the document path ("/sites/s1")
HttpResponse docs_request(ApiContext& ctx, const HttpRequest& req,
                          const std::string& path);
// api_feed.cpp
HttpResponse get_changes(ApiContext& ctx, const HttpRequest& req);
// api_resources.cpp
HttpResponse get_sites(ApiContext& ctx, const HttpRequest& req);
HttpResponse get_blob(ApiContext& ctx, const HttpRequest& req,
                      const std::string& hash);
HttpResponse put_camera(ApiContext& ctx, const HttpRequest& req,
                        const std::string& id);
// PATCH /v1/sites/{id} {"name": ...}: renames a site (planners and admins).
HttpResponse patch_site(ApiContext& ctx, const HttpRequest& req,
                        const std::string& id);

// An id within its scout's own space: "{name}.{id}", so that no scout can
// take a capture or camera id another one will send (docs/api.md). An id
// that begins with the scout's "{name}." already (one the server gave, a
// replayed session) is kept as it is. Token names hold no '.'
// (token_name_problem), so two scouts' spaces never meet.
std::string scoped_id(const Principal& who, const std::string& id);
// The camera a capture of `who` naming camera `id` uses: the scout's own
// (/cameras/{name}.{id}) when it exists; else the operators' /cameras/{id}
// (no owner) or a camera stored under `id` by this scout before ids were
// scoped; else the scout's own id, for a camera stored later.
std::string capture_camera(db::Store& store, const Principal& who,
                           const std::string& id);

// Shared helpers (api.cpp). Store errors are answered with
// error_response (store_errors.h); bodies are parsed with
// http::parse_json_body.
// Parses a query parameter as an integer in [min, max]; nullopt + *error.
std::optional<std::int64_t> int_param(const HttpRequest& req,
                                      const std::string& name,
                                      std::int64_t fallback, std::int64_t min,
                                      std::int64_t max, std::string* error);
bool can_read(const Principal& who, const std::string& doc_path);
// `text` in double quotes: an ETag header's value.
std::string etag_value(std::string_view text);
// `doc` as JSON, with its version as the ETag ("3").
HttpResponse document_response(int status, const db::Document& doc);

}  // namespace arscout::ingest
