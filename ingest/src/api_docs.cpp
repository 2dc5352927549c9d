// /v1/docs/{path}: the document tree over HTTP, versions as ETags.
#include "api_handlers.h"
#include "arscout/db/path.h"

namespace arscout::ingest {
namespace {

// The expected version from If-Match ("N", W/"N" or N) or If-None-Match: *.
// Returns false (with *error) when a header is malformed.
bool expected_version(const HttpRequest& req,
                      std::optional<std::int64_t>* expected,
                      std::string* error) {
  std::string none_match = req.header("if-none-match");
  if (none_match == "*") {
    *expected = 0;
    return true;
  }
  std::string match = req.header("if-match");
  if (match.empty()) return true;
  if (match.rfind("W/", 0) == 0) match = match.substr(2);
  if (match.size() >= 2 && match.front() == '"' && match.back() == '"')
    match = match.substr(1, match.size() - 2);
  try {
    std::size_t used = 0;
    std::int64_t v = std::stoll(match, &used);
    if (used == match.size() && v > 0) {
      *expected = v;
      return true;
    }
  } catch (const std::exception&) {
  }
  *error = "If-Match must be a version ETag like \"3\"";
  return false;
}

HttpResponse get_doc(ApiContext& ctx, const HttpRequest& req,
                     const std::string& path) {
  if (req.query.count("depth")) {
    std::string error;
    auto depth = int_param(req, "depth", 0, 0, db::kMaxPathDepth, &error);
    if (!depth) return HttpResponse::error(400, "bad_request", error);
    Json docs = Json::array();
    for (const auto& d : ctx.store.get_subtree(path, static_cast<int>(*depth)))
      if (can_read(ctx.who, d.path)) docs.push_back(to_json(d));
    return HttpResponse::json(200, Json{{"documents", docs}});
  }
  db::validate_path(path);
  auto doc = ctx.store.get(path);
  if (!doc)
    return HttpResponse::error(404, "not_found", "no document at " + path);
  return document_response(200, *doc);
}

HttpResponse write_doc(ApiContext& ctx, const HttpRequest& req,
                       const std::string& path) {
  db::validate_path(path);
  std::string error;
  std::optional<std::int64_t> expected;
  if (!expected_version(req, &expected, &error))
    return HttpResponse::error(400, "bad_request", error);
  db::WriteOp op;
  op.path = path;
  op.expected_version = expected;
  op.author = ctx.who.name;
  if (req.method == "DELETE") {
    op.type = db::OpType::kDelete;
    auto r = ctx.store.write(op);
    return HttpResponse::json(
        200, Json{{"path", r.path}, {"version", r.version}, {"seq", r.seq}});
  }
  auto body = http::parse_json_body(req.body, &error);
  if (!body) return HttpResponse::error(400, "invalid_json", error);
  if (req.method == "PATCH") {
    op.type = db::OpType::kPatch;
    op.attrs = *body;
  } else {
    if (!body->is_object() || !body->contains("kind") ||
        !(*body)["kind"].is_string())
      return HttpResponse::error(
          422, "invalid_document",
          "a PUT body is {\"kind\": K, \"attrs\": {...}, \"blobs\": {...}}");
    op.type = db::OpType::kPut;
    op.kind = (*body)["kind"];
    op.attrs = body->value("attrs", Json::object());
    if (body->contains("blobs")) {
      const Json& blobs = (*body)["blobs"];
      if (!blobs.is_object())
        return HttpResponse::error(422, "invalid_document",
                                   "blobs must be an object of name: sha256");
      db::BlobRefs refs;
      for (auto& [name, hash] : blobs.items()) {
        if (!hash.is_string())
          return HttpResponse::error(
              422, "invalid_document",
              "blob " + name + " must be a sha256 string");
        refs[name] = hash.get<std::string>();
      }
      op.blobs = refs;
    }
  }
  auto result = ctx.store.write(op);
  auto doc = ctx.store.get(path);
  if (!doc)
    return HttpResponse::error(409, "conflict", path + " changed meanwhile");
  return document_response(result.version == 1 ? 201 : 200, *doc);
}

}  // namespace

HttpResponse docs_request(ApiContext& ctx, const HttpRequest& req,
                          const std::string& path) {
  const std::string& m = req.method;
  // HEAD is GET's answer; the server sends its header alone.
  if (m == "GET" || m == "HEAD")
    return get_doc(ctx, req, path.empty() ? "/" : path);
  if (m == "PUT" || m == "PATCH" || m == "DELETE")
    return write_doc(ctx, req, path);
  HttpResponse r =
      HttpResponse::error(405, "method_not_allowed",
                          "documents allow GET, HEAD, PUT, PATCH, DELETE");
  r.headers.emplace_back("Allow", "GET, HEAD, PUT, PATCH, DELETE");
  return r;
}

}  // namespace arscout::ingest
