#include "mesh_routes.h"

#include <algorithm>
#include <cstring>
#include <memory>
#include <regex>
#include <sstream>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "arscout/db/errors.h"
#include "arscout/db/path.h"
#include "arscout/engine/service.h"
#include "arscout/ingest/store_errors.h"
#include "arscout/util/error.h"
#include "arscout/viewer/site_model.h"
#include "exporters/export_support.h"

namespace arscout::viewer {
namespace {

using db::StoreError;
using http::HttpRequest;
using http::HttpResponse;
using Json = nlohmann::json;

// The first bytes read of a stored GLB: its header and, for the engine's
// GLBs, the whole glTF JSON (about 2 KB).
constexpr std::size_t kHeadBytes = 8192;
// Reads of the model the listing makes while the engine replaces the
// blobs it names (a blob gone is read again from the next version).
constexpr int kListingAttempts = 3;
constexpr const char* kGlbType = "model/gltf-binary";
constexpr const char* kImmutable = "private, max-age=31536000, immutable";

std::uint32_t u32_at(const std::string& bytes, std::size_t at) {
  std::uint32_t v = 0;
  std::memcpy(&v, bytes.data() + at, 4);  // little-endian, as GLB is
  return v;
}

std::string quoted(const std::string& text) {
  std::string out;
  out.reserve(text.size() + 2);
  out.push_back('"');
  out.append(text);
  out.push_back('"');
  return out;
}

// True when the request's If-None-Match lists `etag` (or is "*"): the
// client holds the answer already.
bool client_holds(const HttpRequest& req, const std::string& etag) {
  std::stringstream list(req.header("if-none-match"));
  std::string item;
  while (std::getline(list, item, ',')) {
    const auto first = item.find_first_not_of(" \t");
    const auto last = item.find_last_not_of(" \t");
    if (first == std::string::npos) continue;
    item = item.substr(first, last - first + 1);
    if (item.rfind("W/", 0) == 0) item = item.substr(2);
    if (item == "*" || item == etag) return true;
  }
  return false;
}

HttpResponse not_modified(const std::string& etag,
                          const std::string& cache_control) {
  HttpResponse r;
  r.status = 304;
  r.content_type = "";
  r.headers.emplace_back("ETag", etag);
  r.headers.emplace_back("Cache-Control", cache_control);
  return r;
}

std::string level_url(const std::string& site, const std::string& tile,
                      std::size_t level, const std::string& blob) {
  return "/v1/sites/" + site + "/mesh/" + tile + "/" + std::to_string(level) +
         "?blob=" + blob;
}

// The listing of `tiles` (each with levels), or std::nullopt when one of
// their blobs is not stored (named in *missing).
std::optional<Json> listing(MeshBoxCache& boxes, db::Store& store,
                            const SiteModel& model,
                            const std::vector<engine::MeshTileEntry>& tiles,
                            std::string* missing) {
  Json out = Json::array();
  std::size_t triangles = 0;
  MeshBox all;
  for (const engine::MeshTileEntry& tile : tiles) {
    MeshBox box;
    Json levels = Json::array();
    for (std::size_t l = 0; l < tile.levels.size(); ++l) {
      const engine::MeshTileLevel& level = tile.levels[l];
      const std::optional<GlbBounds> bounds = boxes.get(store, level.blob);
      if (!bounds) {
        *missing = "level " + std::to_string(l) + " of tile " + tile.tile +
                   " (blob " + level.blob + ")";
        return std::nullopt;
      }
      box.add(bounds->box);
      levels.push_back(
          {{"level", l},
           {"url", level_url(model.site, tile.tile, l, level.blob)},
           {"blob", level.blob},
           {"triangles", level.triangles},
           {"error", level.geometric_error},
           {"bytes", bounds->bytes}});
    }
    triangles += tile.levels.front().triangles;
    all.add(box);
    out.push_back({{"tile", tile.tile},
                   {"lo", {box.lo.x(), box.lo.y(), box.lo.z()}},
                   {"hi", {box.hi.x(), box.hi.y(), box.hi.z()}},
                   {"levels", std::move(levels)}});
  }
  return Json{{"site", model.site},
              {"version", model.version},
              {"triangles", triangles},
              {"lo", {all.lo.x(), all.lo.y(), all.lo.z()}},
              {"hi", {all.hi.x(), all.hi.y(), all.hi.z()}},
              {"tiles", std::move(out)}};
}

// GET /v1/sites/{id}/mesh. The listing changes with the model version; a
// client revalidates it (its ETag is the site and the version). A blob
// gone while the model changes is read again from the next version; one
// the same version still names is damaged data.
HttpResponse site_mesh(MeshBoxCache& boxes, db::Store& store,
                       const HttpRequest& req, const std::string& site) {
  std::int64_t last_version = -1;
  std::string missing;
  for (int attempt = 0; attempt < kListingAttempts; ++attempt) {
    const SiteModel model = load_site_model(store, site);
    if (model.version == last_version)
      throw util::Error(util::ErrorKind::kInternal,
                        "the mesh of site " + model.site + " (model version " +
                            std::to_string(model.version) + ") names " +
                            missing + ", which is not stored");
    last_version = model.version;
    const std::string etag =
        quoted(model.site + "-v" + std::to_string(model.version) + "-mesh");
    const auto tiles = formats::nonempty_mesh_tiles(model);
    if (client_holds(req, etag)) return not_modified(etag, "no-cache");
    if (std::optional<Json> body =
            listing(boxes, store, model, tiles, &missing)) {
      HttpResponse r = HttpResponse::json(200, *body);
      r.headers.emplace_back("ETag", etag);
      r.headers.emplace_back("Cache-Control", "no-cache");
      return r;
    }
  }
  throw util::Error(util::ErrorKind::kUnavailable,
                    "the mesh of site " + site +
                        " kept changing while it was read; ask again");
}

struct LevelPath {
  std::string site;
  std::string tile;
  std::size_t level = 0;
};

// "/v1/sites/{id}/mesh/{tile}/{level}" -> its parts, or nullopt.
std::optional<LevelPath> parse_level_path(const std::string& path) {
  static const std::regex form("^/v1/sites/([^/]+)/mesh/([^/]+)/([0-9]{1,6})$");
  std::smatch m;
  if (!std::regex_match(path, m, form)) return std::nullopt;
  return LevelPath{m[1], m[2], std::stoul(m[3])};
}

// The level's blob named by the current model, or a 404 through *missing.
std::string level_blob(const SiteModel& model, const LevelPath& at,
                       std::optional<HttpResponse>* missing) {
  const auto tiles = formats::nonempty_mesh_tiles(model);
  auto tile = std::find_if(
      tiles.begin(), tiles.end(),
      [&](const engine::MeshTileEntry& t) { return t.tile == at.tile; });
  if (tile == tiles.end()) {
    *missing = HttpResponse::error(
        404, "not_found",
        "the mesh of site " + model.site + " has no tile " + at.tile +
            " (GET /v1/sites/" + model.site + "/mesh lists them)");
    return "";
  }
  const std::size_t n = tile->levels.size();
  if (at.level >= n) {
    *missing = HttpResponse::error(
        404, "not_found",
        "mesh tile " + at.tile + " of site " + model.site + " has " +
            std::to_string(n) + " level" + (n == 1 ? "" : "s") + " (0 to " +
            std::to_string(n - 1) + "), not " + std::to_string(at.level));
    return "";
  }
  return tile->levels[at.level].blob;
}

// GET /v1/sites/{id}/mesh/{tile}/{level}[?blob=HASH].
HttpResponse mesh_level(db::Store& store, const HttpRequest& req) {
  const std::optional<LevelPath> at = parse_level_path(req.path);
  if (!at)
    return HttpResponse::error(
        404, "not_found",
        "mesh levels are /v1/sites/{id}/mesh/{tile}/{level}, the level a "
        "number (0 the finest)");
  db::validate_path("/sites/" + at->site);
  const SiteModel model = load_site_model(store, at->site);
  std::optional<HttpResponse> missing;
  const std::string blob = level_blob(model, *at, &missing);
  if (missing) return *missing;
  const auto asked = req.query.find("blob");
  const bool pinned = asked != req.query.end();
  if (pinned && asked->second != blob)
    return HttpResponse::error(
        410, "gone",
        "level " + std::to_string(at->level) + " of mesh tile " + at->tile +
            " of site " + model.site +
            " has changed since that listing; fetch the mesh again");
  // Pinned to its blob, the answer never changes; unpinned it follows the
  // model, and a client revalidates it.
  const std::string cache = pinned ? kImmutable : "private, no-cache";
  const std::string etag = quoted(blob);
  if (client_holds(req, etag)) return not_modified(etag, cache);
  HttpResponse r;
  r.content_type = kGlbType;
  r.body = store.get_blob(blob);
  r.headers.emplace_back("ETag", etag);
  r.headers.emplace_back("Cache-Control", cache);
  return r;
}

// The store's and util's errors as the API's statuses, as on every route.
template <typename F>
HttpResponse answering_errors(F&& make) {
  try {
    return make();
  } catch (const StoreError& e) {
    return ingest::error_response(e);
  } catch (const util::Error& e) {
    return ingest::error_response(e);
  }
}

// "/v1/sites/{id}/mesh" -> id, or "".
std::string listing_site(const std::string& path) {
  static const std::regex form("^/v1/sites/([^/]+)/mesh$");
  std::smatch m;
  return std::regex_match(path, m, form) ? std::string(m[1]) : "";
}

}  // namespace

std::optional<std::string> glb_json_chunk(const std::string& head,
                                          std::size_t* need) {
  if (head.size() < 20 || head.compare(0, 4, "glTF") != 0 ||
      u32_at(head, 4) != 2 || u32_at(head, 16) != 0x4E4F534Au)
    throw std::runtime_error("not a GLB (glTF 2.0 binary) with a JSON chunk");
  const std::size_t length = u32_at(head, 12);
  if (length > u32_at(head, 8))
    throw std::runtime_error("the GLB's JSON chunk runs past its end");
  *need = 20 + length;
  if (head.size() < *need) return std::nullopt;
  return head.substr(20, length);
}

MeshBox gltf_position_box(const std::string& json) {
  const Json gltf = Json::parse(json);
  MeshBox box;
  const Json& accessors = gltf.at("accessors");
  for (const Json& mesh : gltf.value("meshes", Json::array()))
    for (const Json& primitive : mesh.at("primitives")) {
      const Json& a =
          accessors.at(primitive.at("attributes").at("POSITION").get<int>());
      if (!a.contains("min") || !a.contains("max"))
        throw std::runtime_error("a POSITION accessor has no min and max");
      MeshBox part;
      for (int i = 0; i < 3; ++i) {
        part.lo[i] = a["min"].at(i).get<double>();
        part.hi[i] = a["max"].at(i).get<double>();
      }
      box.add(part);
    }
  if (box.empty()) throw std::runtime_error("the glTF has no positions");
  const Json nodes = gltf.value("nodes", Json::array());
  if (!nodes.empty() && nodes[0].contains("translation"))
    for (int i = 0; i < 3; ++i) {
      const double t = nodes[0]["translation"].at(i).get<double>();
      box.lo[i] += t;
      box.hi[i] += t;
    }
  return box;
}

std::optional<GlbBounds> MeshBoxCache::get(db::Store& store,
                                           const std::string& hash) {
  {
    std::lock_guard lock(mutex_);
    if (auto it = entries_.find(hash); it != entries_.end()) return it->second;
  }
  const std::optional<db::BlobInfo> info = store.blob_info(hash);
  if (!info) return std::nullopt;
  GlbBounds bounds;
  bounds.bytes = info->size;
  try {
    std::ostringstream head;
    store.read_blob(hash, head, 0,
                    std::min<std::int64_t>(info->size, kHeadBytes));
    std::size_t need = 0;
    std::optional<std::string> json = glb_json_chunk(head.str(), &need);
    if (!json && static_cast<std::int64_t>(need) <= info->size) {
      std::ostringstream whole;
      store.read_blob(hash, whole, 0, static_cast<std::int64_t>(need));
      json = glb_json_chunk(whole.str(), &need);
    }
    if (!json) throw std::runtime_error("the GLB is cut short");
    bounds.box = gltf_position_box(*json);
  } catch (const StoreError& e) {
    if (e.code() == db::ErrorCode::kUnknownBlob) return std::nullopt;
    throw;
  } catch (const std::exception& e) {
    throw util::Error(util::ErrorKind::kInternal,
                      "mesh blob " + hash + ": " + e.what());
  }
  std::lock_guard lock(mutex_);
  if (entries_.size() >= kMaxEntries) entries_.clear();
  entries_[hash] = bounds;
  return bounds;
}

std::size_t MeshBoxCache::size() const {
  std::lock_guard lock(mutex_);
  return entries_.size();
}

std::vector<ingest::ApiRoute> mesh_routes(db::Store& store) {
  auto boxes = std::make_shared<MeshBoxCache>();
  ingest::ApiRoute tiles;
  tiles.name = "GET /v1/sites/*/mesh";
  tiles.methods = {"GET"};
  tiles.pattern = "/v1/sites/*/mesh";
  tiles.handle = [&store, boxes](const HttpRequest& req,
                                 const ingest::Principal&) {
    return answering_errors([&] {
      const std::string site = listing_site(req.path);
      db::validate_path("/sites/" + site);  // ".." is no id
      return site_mesh(*boxes, store, req, site);
    });
  };
  ingest::ApiRoute level;
  level.name = "GET /v1/sites/*/mesh/*";
  level.methods = {"GET"};
  level.pattern = "/v1/sites/*/mesh/*";
  level.handle = [&store](const HttpRequest& req, const ingest::Principal&) {
    return answering_errors([&] { return mesh_level(store, req); });
  };
  return {std::move(tiles), std::move(level)};
}

}  // namespace arscout::viewer
