#include "arscout/viewer/routes.h"
#include "arscout/util/error.h"

#include <array>
#include <cmath>
#include <memory>
#include <regex>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "arscout/db/errors.h"
#include "arscout/db/path.h"
#include "arscout/documents/document_error.h"
#include "arscout/documents/geojson.h"
#include "arscout/ingest/image_budget.h"
#include "arscout/ingest/store_errors.h"
#include "arscout/viewer/exports.h"
#include "arscout/viewer/overlay.h"
#include "cloud_octree.h"
#include "export_cache.h"
#include "mesh_routes.h"
#include "site_coverage.h"

namespace arscout::viewer {
namespace {

// Built exports kept in memory (export_cache.h): a few versions of a large
// site's LAS and 3D Tiles files.
constexpr std::size_t kExportCacheBytes = 256u << 20;

using db::StoreError;
using http::HttpRequest;
using http::HttpResponse;

// "/v1/{collection}/{id}/{leaf}" -> id, or "" when the path is not that.
std::string id_between(const std::string& path, const std::string& collection,
                       const std::string& leaf) {
  const std::string head = "/v1/" + collection + "/";
  const std::string tail = "/" + leaf;
  if (path.size() <= head.size() + tail.size() ||
      path.compare(0, head.size(), head) != 0 ||
      path.compare(path.size() - tail.size(), tail.size(), tail) != 0)
    return "";
  std::string id =
      path.substr(head.size(), path.size() - head.size() - tail.size());
  return id.find('/') == std::string::npos ? id : "";
}

// An integer query parameter in [lo, hi], else a 400 through *bad.
int int_query(const HttpRequest& req, const std::string& name, int fallback,
              int lo, int hi, std::optional<HttpResponse>* bad) {
  auto it = req.query.find(name);
  if (it == req.query.end()) return fallback;
  try {
    size_t used = 0;
    const int v = std::stoi(it->second, &used);
    if (used == it->second.size() && v >= lo && v <= hi) return v;
  } catch (const std::exception&) {
  }
  *bad = HttpResponse::error(
      400, "bad_request",
      "query parameter '" + name + "' must be an integer in [" +
          std::to_string(lo) + ", " + std::to_string(hi) + "]");
  return fallback;
}

std::optional<Cloud> cloud_query(const HttpRequest& req,
                                 std::optional<HttpResponse>* bad) {
  auto it = req.query.find("cloud");
  if (it == req.query.end() || it->second == "dense") return Cloud::kDense;
  if (it->second == "sparse") return Cloud::kSparse;
  *bad = HttpResponse::error(400, "bad_request",
                             "query parameter 'cloud' must be dense or sparse");
  return std::nullopt;
}

std::optional<OverlayDraw> draw_query(const HttpRequest& req,
                                      std::optional<HttpResponse>* bad) {
  auto it = req.query.find("draw");
  if (it == req.query.end() || it->second == "points")
    return OverlayDraw::kPoints;
  if (it->second == "mesh") return OverlayDraw::kMesh;
  *bad = HttpResponse::error(400, "bad_request",
                             "query parameter 'draw' must be points or mesh");
  return std::nullopt;
}

HttpResponse jpeg(std::string bytes) {
  HttpResponse r;
  r.content_type = "image/jpeg";
  r.body = std::move(bytes);
  return r;
}

HttpResponse overlay(db::Store& store, const HttpRequest& req,
                     const std::string& capture) {
  std::optional<HttpResponse> bad;
  OverlayOptions options;
  options.max_side = int_query(req, "max_side", 1280, 64, 4096, &bad);
  options.min_support =
      int_query(req, "min_support", engine::kConfidentSupport, 0, 255, &bad);
  // Percent, so that the value is an integer like the others.
  options.opacity =
      int_query(req, "opacity", static_cast<int>(options.opacity * 100), 0, 100,
                &bad) /
      100.0;
  if (auto cloud = cloud_query(req, &bad)) options.cloud = *cloud;
  if (auto draw = draw_query(req, &bad)) options.draw = *draw;
  if (bad) return *bad;
  HttpResponse r = jpeg(overlay_jpeg(store, capture, options));
  r.headers.emplace_back("Cache-Control", "no-cache");
  return r;
}

std::string thumbnail_jpeg(db::Store& store, const std::string& capture,
                           int size) {
  const auto doc = store.get("/captures/" + capture);
  if (!doc || !doc->blobs.count("image"))
    throw util::Error(util::ErrorKind::kNotFound, "no capture " + capture);
  const std::string bytes = store.get_blob(doc->blobs.at("image"));
  // A reduced decode is far quicker than decoding 12 MP and shrinking.
  const int width = doc->attrs.value("width", 0);
  const int height = doc->attrs.value("height", 0);
  const int factor = std::max(width, height) / std::max(size, 1);
  const int flag = factor >= 8   ? cv::IMREAD_REDUCED_COLOR_8
                   : factor >= 4 ? cv::IMREAD_REDUCED_COLOR_4
                   : factor >= 2 ? cv::IMREAD_REDUCED_COLOR_2
                                 : cv::IMREAD_COLOR;
  std::string why;
  cv::Mat image = ingest::decode_within_budget(
      bytes, flag | cv::IMREAD_IGNORE_ORIENTATION, &why);
  if (image.empty())
    throw util::Error(util::ErrorKind::kInternal,
                      "the photo of capture " + capture + ": " + why);
  const double scale = std::min(
      1.0, static_cast<double>(size) / std::max(image.cols, image.rows));
  if (scale < 1)
    cv::resize(image, image, cv::Size(), scale, scale, cv::INTER_AREA);
  std::vector<uchar> out;
  cv::imencode(".jpg", image, out, {cv::IMWRITE_JPEG_QUALITY, 80});
  return std::string(out.begin(), out.end());
}

HttpResponse thumbnail(db::Store& store, const HttpRequest& req,
                       const std::string& capture) {
  std::optional<HttpResponse> bad;
  const int size = int_query(req, "size", 256, 16, 1024, &bad);
  if (bad) return *bad;
  HttpResponse r = jpeg(thumbnail_jpeg(store, capture, size));
  // A capture's photo never changes.
  r.headers.emplace_back("Cache-Control", "private, max-age=86400");
  return r;
}

HttpResponse site_export(ExportCache& cache, db::Store& store,
                         const HttpRequest& req, const std::string& site) {
  auto it = req.query.find("format");
  const Exporter* format =
      it == req.query.end() ? nullptr : find_exporter(it->second);
  if (!format)
    return HttpResponse::error(400, "bad_request",
                               "query parameter 'format' must be " +
                                   exporter_names(", ") +
                                   " (GET /v1/exports lists them)");
  std::optional<HttpResponse> bad;
  ExportOptions options;
  if (auto cloud = cloud_query(req, &bad)) options.cloud = *cloud;
  if (bad) return *bad;
  // Checked with the site's location by export_site (422 when they do not
  // fit it).
  if (auto crs = req.query.find("crs"); crs != req.query.end())
    options.crs = crs->second;
  if (auto heights = req.query.find("heights"); heights != req.query.end())
    options.heights = heights->second;
  // Keyed by the model version read now: a version committed while the
  // file is built gets a key of its own on the next request.
  const SiteModel model = load_site_model(store, site);
  const std::string key =
      model.site + "/" + std::to_string(model.version) + "/" +
      std::string(format->name) + "/" +
      (options.cloud == Cloud::kDense ? "dense" : "sparse") + "/" +
      options.crs + "/" + options.heights;
  const std::shared_ptr<const ExportFile> file = cache.get(
      key, [&] { return export_site(store, site, *format, options); });
  HttpResponse r;
  r.content_type = file->content_type;
  r.body_reader = http::shared_bytes_reader(
      std::shared_ptr<const std::string>(file, &file->bytes));
  r.headers.emplace_back("Content-Disposition",
                         "attachment; filename=\"" + file->filename + "\"");
  return r;
}

// The site's capture documents (those whose `site` is it), by path: what
// a viewer lists without fetching every capture on the server.
HttpResponse site_captures(db::Store& store, const std::string& site) {
  db::Query query;
  query.pattern = "/captures/*";
  query.equals = {{"site", site}};
  query.limit = 100000;
  Json docs = Json::array();
  for (const db::Document& doc : store.query(query))
    docs.push_back(db::to_json(doc));
  return HttpResponse::json(200, Json{{"captures", docs}});
}

// The registered cameras on a map (documents/geojson.h); 422 before the
// model is geo-registered.
HttpResponse site_cameras_geojson(db::Store& store, const std::string& site) {
  const SiteModel model = load_site_model(store, site);
  try {
    return HttpResponse::geojson(documents::cameras_geojson(model.document));
  } catch (const documents::DocumentError& e) {
    return HttpResponse::error(422, "not_geo_registered", e.what());
  }
}

// A finite number from the query, else a 400 through *bad.
double number_query(const HttpRequest& req, const std::string& name,
                    std::optional<HttpResponse>* bad) {
  auto it = req.query.find(name);
  try {
    size_t used = 0;
    const double v = it == req.query.end() ? NAN : std::stod(it->second, &used);
    if (used == it->second.size() && std::isfinite(v)) return v;
  } catch (const std::exception&) {
  }
  *bad = HttpResponse::error(400, "bad_request",
                             "query parameter '" + name +
                                 "' must be a number (metres in the site's "
                                 "ENU frame)");
  return 0;
}

std::string text_query(const HttpRequest& req, const std::string& name,
                       const std::string& fallback) {
  auto it = req.query.find(name);
  return it == req.query.end() ? fallback : it->second;
}

// A point of the site's ENU frame in an output CRS: the viewer's picked
// point, in the coordinates the planner's GIS uses.
HttpResponse site_coordinates(db::Store& store, const HttpRequest& req,
                              const std::string& site) {
  std::optional<HttpResponse> bad;
  std::array<double, 3> enu{};
  for (int a = 0; a < 3 && !bad; ++a)
    enu[a] = number_query(req, std::string(1, "xyz"[a]), &bad);
  if (bad) return *bad;
  const SitePoint p =
      project_site_point(store, site, enu, text_query(req, "crs", "utm"),
                         text_query(req, "heights", "ellipsoid"));
  return HttpResponse::json(200, Json{{"enu", p.enu},
                                      {"wgs84",
                                       {{"lat", p.wgs84.lat},
                                        {"lon", p.wgs84.lon},
                                        {"height", p.wgs84.alt}}},
                                      {"crs", p.crs_code},
                                      {"crs_name", p.crs_name},
                                      {"geographic", p.geographic},
                                      {"coordinates", p.xyz}});
}

// The hierarchy of the site's current cloud, built on the first request
// for its version (cloud_octree.h).
HttpResponse site_octree(CloudOctreeCache& cache, db::Store& store,
                         const HttpRequest& req, const std::string& site) {
  std::optional<HttpResponse> bad;
  const std::optional<Cloud> cloud = cloud_query(req, &bad);
  if (bad) return *bad;
  HttpResponse r =
      HttpResponse::json(200, cache.current(store, site, *cloud)->hierarchy);
  r.headers.emplace_back("Cache-Control", "no-cache");
  return r;
}

struct NodePath {
  std::string site;
  std::int64_t version = 0;
  std::string node;
};

// "/v1/sites/{id}/octree/{version}/{node}.bin" -> its parts, or nullopt.
std::optional<NodePath> parse_node_path(const std::string& path) {
  static const std::regex form(
      "^/v1/sites/([^/]+)/octree/([0-9]{1,18})/(r[0-7]{0,32})\\.bin$");
  std::smatch m;
  if (!std::regex_match(path, m, form)) return std::nullopt;
  return NodePath{m[1], std::stoll(m[2]), m[3]};
}

// One node's points. Node URLs name their version, so they never change;
// a version no longer current (nor kept) is 410: the viewer then fetches
// the hierarchy again.
HttpResponse octree_node(CloudOctreeCache& cache, db::Store& store,
                         const HttpRequest& req) {
  const std::optional<NodePath> at = parse_node_path(req.path);
  if (!at)
    return HttpResponse::error(
        404, "not_found",
        "octree nodes are /v1/sites/{id}/octree/{version}/{node}.bin");
  db::validate_path("/sites/" + at->site);
  std::optional<HttpResponse> bad;
  const std::optional<Cloud> cloud = cloud_query(req, &bad);
  if (bad) return *bad;
  const std::string name = *cloud == Cloud::kDense ? "dense" : "sparse";
  auto octree = cache.find(at->site, at->version, name);
  if (!octree) octree = cache.current(store, at->site, *cloud);
  if (octree->version != at->version || octree->cloud != name)
    return HttpResponse::error(
        410, "gone",
        "version " + std::to_string(at->version) + " of site " + at->site +
            "'s " + name +
            " cloud is no longer served; fetch its octree again");
  const auto node = octree->node_bytes.find(at->node);
  if (node == octree->node_bytes.end())
    return HttpResponse::error(404, "not_found",
                               "the octree has no node " + at->node);
  HttpResponse r;
  r.content_type = "application/octet-stream";
  r.body = node->second;
  r.headers.emplace_back("Cache-Control",
                         "private, max-age=31536000, immutable");
  return r;
}

// GET /v1/{collection}/{id}/{leaf}. Other methods get ingest's 405, and a
// db::StoreError or util::Error the API's status for it, as on every other
// route.
ingest::ApiRoute route(
    const std::string& name, const std::string& collection,
    const std::string& leaf,
    std::function<HttpResponse(const HttpRequest&, const std::string&)> make) {
  ingest::ApiRoute r;
  r.name = name;
  r.methods = {"GET"};
  r.pattern = "/v1/" + collection + "/*/" + leaf;
  r.handle = [collection, leaf, make](const HttpRequest& req,
                                      const ingest::Principal&) {
    const std::string id = id_between(req.path, collection, leaf);
    try {
      db::validate_path("/" + collection + "/" + id);  // ".." is no id
      return make(req, id);
    } catch (const StoreError& e) {
      return ingest::error_response(e);
    } catch (const util::Error& e) {
      return ingest::error_response(e);
    }
  };
  return r;
}

// GET /v1/exports: the export formats, as the registry lists them, for
// clients that offer them (the web viewer's export buttons).
ingest::ApiRoute exports_route() {
  ingest::ApiRoute r;
  r.name = "GET /v1/exports";
  r.methods = {"GET"};
  r.pattern = "/v1/exports";
  r.handle = [](const HttpRequest&, const ingest::Principal&) {
    Json formats = Json::array();
    for (const Exporter* e : exporters()) {
      Json options = Json::array();
      if (e->takes_cloud) options.push_back("cloud");
      if (e->takes_crs) options.insert(options.end(), {"crs", "heights"});
      formats.push_back({{"name", e->name},
                         {"extension", e->extension},
                         {"mime_type", e->mime_type},
                         {"summary", e->summary},
                         {"options", options}});
    }
    return HttpResponse::json(200, Json{{"formats", formats}});
  };
  return r;
}

}  // namespace

ingest::ApiRoute octree_node_route(db::Store& store,
                                   std::shared_ptr<CloudOctreeCache> cache) {
  ingest::ApiRoute r;
  r.name = "GET /v1/sites/*/octree/*";
  r.methods = {"GET"};
  r.pattern = "/v1/sites/*/octree/*";
  r.handle = [&store, cache](const HttpRequest& req, const ingest::Principal&) {
    try {
      return octree_node(*cache, store, req);
    } catch (const StoreError& e) {
      return ingest::error_response(e);
    } catch (const util::Error& e) {
      return ingest::error_response(e);
    }
  };
  return r;
}

std::vector<ingest::ApiRoute> viewer_routes(db::Store& store) {
  db::Store* s = &store;
  auto octrees = std::make_shared<CloudOctreeCache>();
  auto exports = std::make_shared<ExportCache>(kExportCacheBytes);
  auto coverage = std::make_shared<CoverageCache>();
  ingest::ApiRoute export_route =
      route("GET /v1/sites/*/export", "sites", "export",
            [s, exports](const HttpRequest& req, const std::string& id) {
              return site_export(*exports, *s, req, id);
            });
  export_route.runs_long = true;
  std::vector<ingest::ApiRoute> routes = {
      route("GET /v1/captures/*/overlay.jpg", "captures", "overlay.jpg",
            [s](const HttpRequest& req, const std::string& id) {
              return overlay(*s, req, id);
            }),
      route("GET /v1/captures/*/thumbnail.jpg", "captures", "thumbnail.jpg",
            [s](const HttpRequest& req, const std::string& id) {
              return thumbnail(*s, req, id);
            }),
      route("GET /v1/sites/*/captures", "sites", "captures",
            [s](const HttpRequest&, const std::string& id) {
              return site_captures(*s, id);
            }),
      route("GET /v1/sites/*/cameras.geojson", "sites", "cameras.geojson",
            [s](const HttpRequest&, const std::string& id) {
              return site_cameras_geojson(*s, id);
            }),
      std::move(export_route),
      exports_route(),
      route("GET /v1/sites/*/octree", "sites", "octree",
            [s, octrees](const HttpRequest& req, const std::string& id) {
              return site_octree(*octrees, *s, req, id);
            }),
      octree_node_route(store, octrees),
      route("GET /v1/sites/*/coordinates", "sites", "coordinates",
            [s](const HttpRequest& req, const std::string& id) {
              return site_coordinates(*s, req, id);
            }),
      route("GET /v1/sites/*/coverage", "sites", "coverage",
            [s, coverage](const HttpRequest& req, const std::string& id) {
              std::optional<HttpResponse> bad;
              const int max = int_query(req, "max", 5, 0, 20, &bad);
              if (bad) return *bad;
              return site_coverage(*coverage, *s, req, id, max);
            }),
  };
  for (ingest::ApiRoute& r : mesh_routes(store)) routes.push_back(std::move(r));
  return routes;
}

std::vector<http::StaticMount> web_mounts(const std::string& web_root) {
  return {{"/", web_root},
          {"/vendor/three/", web_root + "/node_modules/three"}};
}

std::string default_web_root() { return ARSCOUT_WEB_ROOT; }

}  // namespace arscout::viewer
