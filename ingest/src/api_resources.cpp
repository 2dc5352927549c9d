// /v1/sites, /v1/blobs/{sha256}, /v1/cameras/{id}.
#include <sstream>

#include "api_handlers.h"
#include "arscout/db/path.h"
#include "arscout/documents/document_error.h"
#include "arscout/documents/geojson.h"

namespace arscout::ingest {
namespace {

// "LAT,LON" -> the two numbers, or nullopt.
std::optional<std::pair<double, double>> parse_near(const std::string& text) {
  std::size_t comma = text.find(',');
  if (comma == std::string::npos) return std::nullopt;
  try {
    std::size_t a = 0, b = 0;
    double lat = std::stod(text.substr(0, comma), &a);
    double lon = std::stod(text.substr(comma + 1), &b);
    if (a != comma || b != text.size() - comma - 1) return std::nullopt;
    return std::make_pair(lat, lon);
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

std::string sniff_content_type(std::string_view head) {
  if (head.substr(0, 3) == "\xFF\xD8\xFF") return "image/jpeg";
  if (head.substr(0, 8) == "\x89PNG\r\n\x1a\n") return "image/png";
  if (head.substr(0, 4) == "ply\n" || head.substr(0, 5) == "ply\r\n")
    return "application/x-ply";
  return "application/octet-stream";
}

// A single "bytes=A-B" / "bytes=A-" / "bytes=-N" range within size; false
// when malformed or unsatisfiable.
bool parse_range(const std::string& header, std::int64_t size,
                 std::int64_t* first, std::int64_t* last) {
  if (header.rfind("bytes=", 0) != 0) return false;
  std::string spec = header.substr(6);
  if (spec.find(',') != std::string::npos) return false;  // one range only
  std::size_t dash = spec.find('-');
  if (dash == std::string::npos) return false;
  std::string a = spec.substr(0, dash), b = spec.substr(dash + 1);
  auto number = [](const std::string& s, std::int64_t* out) {
    if (s.empty() || s.find_first_not_of("0123456789") != std::string::npos ||
        s.size() > 18)
      return false;
    *out = std::stoll(s);
    return true;
  };
  std::int64_t x = 0, y = 0;
  if (a.empty()) {  // suffix: the last N bytes
    if (!number(b, &y) || y == 0 || size == 0) return false;
    *first = std::max<std::int64_t>(0, size - y);
    *last = size - 1;
    return true;
  }
  if (!number(a, &x) || x >= size) return false;
  if (b.empty()) {
    y = size - 1;
  } else if (!number(b, &y) || y < x) {
    return false;
  }
  *first = x;
  *last = std::min(y, size - 1);
  return true;
}

}  // namespace

// Sites as map points; one that does not read as a site (written by hand)
// is left off the map rather than failing it.
Json sites_geojson(const std::vector<db::Document>& docs) {
  std::vector<std::pair<std::string, documents::Site>> sites;
  for (const db::Document& d : docs) {
    const std::string id(db::leaf_name(d.path));
    try {
      sites.emplace_back(id, documents::site_from_json(d.attrs, id));
    } catch (const documents::DocumentError&) {
    }
  }
  return documents::sites_geojson(sites);
}

HttpResponse get_sites(ApiContext& ctx, const HttpRequest& req) {
  db::Query q;
  q.pattern = "/sites/*";
  if (auto it = req.query.find("near"); it != req.query.end()) {
    auto near = parse_near(it->second);
    if (!near)
      return HttpResponse::error(400, "bad_request",
                                 "near must be LAT,LON in decimal degrees");
    double radius = 1000;
    if (auto r = req.query.find("radius"); r != req.query.end()) {
      try {
        std::size_t used = 0;
        radius = std::stod(r->second, &used);
        if (used != r->second.size()) radius = -1;
      } catch (const std::exception&) {
        radius = -1;
      }
      if (!(radius >= 0) || radius > 2.1e7)
        return HttpResponse::error(400, "bad_request",
                                   "radius must be metres in [0, 21000000]");
    }
    q.near = db::GeoRadius{near->first, near->second, radius};
  }
  const auto format = req.query.find("format");
  if (format != req.query.end() && format->second != "json" &&
      format->second != "geojson")
    return HttpResponse::error(400, "bad_request",
                               "format must be json or geojson");
  const auto docs = ctx.store.query(q);
  if (format != req.query.end() && format->second == "geojson")
    return HttpResponse::geojson(sites_geojson(docs));
  Json sites = Json::array();
  for (const auto& d : docs) sites.push_back(to_json(d));
  return HttpResponse::json(200, Json{{"sites", sites}});
}

HttpResponse get_blob(ApiContext& ctx, const HttpRequest& req,
                      const std::string& hash) {
  auto info =
      ctx.store.blob_info(hash);  // throws invalid_argument on a bad hash
  if (!info) return HttpResponse::error(404, "unknown_blob", "no blob " + hash);
  std::ostringstream head;
  ctx.store.read_blob(hash, head, 0, std::min<std::int64_t>(8, info->size));
  HttpResponse r;
  r.content_type = sniff_content_type(head.str());
  r.headers.emplace_back("ETag", etag_value(hash));
  r.headers.emplace_back("Accept-Ranges", "bytes");
  r.headers.emplace_back("Cache-Control",
                         "public, max-age=31536000, immutable");
  std::int64_t first = 0, last = info->size - 1;
  std::string range = req.header("range");
  if (!range.empty()) {
    if (!parse_range(range, info->size, &first, &last)) {
      HttpResponse bad = HttpResponse::error(
          416, "range_not_satisfiable",
          "Range '" + range + "' is not one satisfiable byte range of " +
              std::to_string(info->size));
      bad.headers.emplace_back("Content-Range",
                               "bytes */" + std::to_string(info->size));
      return bad;
    }
    r.status = 206;
    r.headers.emplace_back("Content-Range", "bytes " + std::to_string(first) +
                                                "-" + std::to_string(last) +
                                                "/" +
                                                std::to_string(info->size));
  }
  // Read a piece at a time as the client takes it (http_types.h): a
  // 50 MB photo fetched by 150 clients that never read held 7.5 GB when it
  // was read whole into each response.
  // Pieces end at the store's chunks (1 MiB rows), so each reads one row.
  constexpr std::int64_t kStoreChunk = 1 << 20;
  db::Store* store = &ctx.store;
  r.body_reader = HttpResponse::BodyReader{
      info->size > 0 ? last - first + 1 : 0,
      [store, hash, first](std::int64_t offset, std::size_t length) {
        const std::int64_t at = first + offset;
        const std::int64_t to_chunk_end =
            (at / kStoreChunk + 1) * kStoreChunk - at;
        std::ostringstream piece;
        store->read_blob(
            hash, piece, at,
            std::min(static_cast<std::int64_t>(length), to_chunk_end));
        return std::move(piece).str();
      }};
  return r;
}

HttpResponse put_camera(ApiContext& ctx, const HttpRequest& req,
                        const std::string& id) {
  db::validate_path("/cameras/" + id);
  if (id.find('/') != std::string::npos)
    return HttpResponse::error(400, "invalid_path",
                               "a camera id is one path segment");
  // Intrinsics and a few statistics take well under a kilobyte; the cap
  // keeps a camera from becoming a free-form store.
  constexpr std::size_t kMaxCameraBytes = 16 * 1024;
  if (req.body.size() > kMaxCameraBytes)
    return HttpResponse::error(413, "payload_too_large",
                               "a camera document is at most 16 KiB");
  std::string error;
  auto body = http::parse_json_body(req.body, &error);
  if (!body) return HttpResponse::error(400, "invalid_json", error);
  error = documents::validate_camera(*body);
  if (!error.empty()) return HttpResponse::error(422, "unprocessable", error);
  // A scout's camera ids are its own, as its capture ids are: "phone" from
  // alice is /cameras/alice.phone, so no scout can take an id another one
  // will use. An admin's are the operators' (/cameras/phone, no owner),
  // which every scout's captures may name. Only the owner or an admin may
  // change a camera. The version read is the version expected, so a race
  // with another writer is a 409, not a lost ownership check.
  const bool admin = ctx.who.role == Role::kAdmin;
  const std::string path = "/cameras/" + (admin ? id : scoped_id(ctx.who, id));
  db::validate_path(path);  // the name made it longer
  const auto current = ctx.store.get(path);
  const std::string owner =
      current ? current->attrs.value("owner", "") : (admin ? "" : ctx.who.name);
  if (!admin && owner != ctx.who.name)
    return HttpResponse::error(
        403, "forbidden",
        path + " belongs to " +
            (owner.empty() ? std::string("the operators") : owner));
  if (owner.empty())
    body->erase("owner");
  else
    (*body)["owner"] = owner;
  db::WriteOp op =
      db::WriteOp::put(path, "camera", *body, current ? current->version : 0);
  op.author = ctx.who.name;
  ctx.store.write(op);
  auto doc = ctx.store.get(path);
  HttpResponse r = document_response(doc->version == 1 ? 201 : 200, *doc);
  r.headers.emplace_back("Location", "/v1/docs" + path);
  return r;
}

std::string capture_camera(db::Store& store, const Principal& who,
                           const std::string& id) {
  const std::string own = scoped_id(who, id);
  if (own == id || store.get("/cameras/" + own)) return own;
  const auto shared = store.get("/cameras/" + id);
  if (shared) {
    const std::string owner = shared->attrs.value("owner", "");
    if (owner.empty() || owner == who.name) return id;
  }
  return own;
}

namespace {

// A site name a person gave: trimmed, 1-120 characters, no control
// characters. "" (with *problem set) when it is not one.
std::string site_name(const Json& body, std::string* problem) {
  if (!body.is_object() || body.size() != 1 || !body.contains("name") ||
      !body["name"].is_string()) {
    *problem = "the body must be {\"name\": \"...\"}";
    return "";
  }
  std::string name = body["name"].get<std::string>();
  const auto first = name.find_first_not_of(" \t");
  name = first == std::string::npos
             ? ""
             : name.substr(first, name.find_last_not_of(" \t") - first + 1);
  if (name.empty() || name.size() > 120) {
    *problem = "a site name has 1 to 120 characters";
    return "";
  }
  for (unsigned char c : name)
    if (c < 0x20 || c == 0x7f) {
      *problem = "a site name holds no control characters";
      return "";
    }
  return name;
}

}  // namespace

HttpResponse patch_site(ApiContext& ctx, const HttpRequest& req,
                        const std::string& id) {
  if (id.empty() || id.find('/') != std::string::npos)
    return HttpResponse::error(404, "not_found",
                               "sites are renamed at /v1/sites/{id}");
  if (ctx.who.role == Role::kScout)
    return HttpResponse::error(403, "forbidden",
                               "scouts may not rename sites (planners and "
                               "admins may)");
  db::validate_path("/sites/" + id);
  std::string problem;
  const auto body = http::parse_json_body(req.body, &problem);
  if (!body) return HttpResponse::error(400, "invalid_json", problem);
  const std::string name = site_name(*body, &problem);
  if (name.empty()) return HttpResponse::error(422, "unprocessable", problem);
  const auto site = ctx.store.get("/sites/" + id);
  if (!site || site->kind != "site")
    return HttpResponse::error(404, "not_found", "no site " + id);
  if (const std::string into = site->attrs.value("merged_into", "");
      !into.empty())
    return HttpResponse::error(
        409, "conflict",
        "site " + id + " grew into site " + into + ": rename that one");
  // The version read is the version expected: a rename racing the engine's
  // commit of the site is a 409 to retry, never a lost write.
  db::WriteOp op =
      db::WriteOp::patch(site->path, Json{{"name", name}}, site->version);
  op.author = ctx.who.name;
  ctx.store.write(op);
  return document_response(200, *ctx.store.get(site->path));
}

}  // namespace arscout::ingest
