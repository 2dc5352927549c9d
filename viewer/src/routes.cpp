#include "arscout/viewer/routes.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "arscout/db/errors.h"
#include "arscout/db/path.h"
#include "arscout/documents/document_error.h"
#include "arscout/documents/geojson.h"
#include "arscout/ingest/image_budget.h"
#include "arscout/viewer/exports.h"
#include "arscout/viewer/overlay.h"

namespace arscout::viewer {
namespace {

using db::ErrorCode;
using db::StoreError;
using ingest::HttpRequest;
using ingest::HttpResponse;

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
  if (auto cloud = cloud_query(req, &bad)) options.cloud = *cloud;
  if (bad) return *bad;
  HttpResponse r = jpeg(overlay_jpeg(store, capture, options));
  r.headers.emplace_back("Cache-Control", "no-cache");
  return r;
}

std::string thumbnail_jpeg(db::Store& store, const std::string& capture,
                           int size) {
  const auto doc = store.get("/captures/" + capture);
  if (!doc || !doc->blobs.count("image"))
    throw StoreError(ErrorCode::kNotFound, "no capture " + capture);
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
    throw StoreError(ErrorCode::kInternal,
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

HttpResponse site_export(db::Store& store, const HttpRequest& req,
                         const std::string& site) {
  auto it = req.query.find("format");
  const auto format =
      it == req.query.end() ? std::nullopt : parse_export_format(it->second);
  if (!format)
    return HttpResponse::error(
        400, "bad_request",
        "query parameter 'format' must be ply, colmap, geocsv, ecef-ply, las "
        "or 3dtiles");
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
  ExportFile file = export_site(store, site, *format, options);
  HttpResponse r;
  r.content_type = file.content_type;
  r.body = std::move(file.bytes);
  r.headers.emplace_back("Content-Disposition",
                         "attachment; filename=\"" + file.filename + "\"");
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

// GET /v1/{collection}/{id}/{leaf}. Other methods get ingest's 405, and a
// db::StoreError the API's status for it, as on every other route.
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
    }
  };
  return r;
}

}  // namespace

std::vector<ingest::ApiRoute> viewer_routes(db::Store& store) {
  db::Store* s = &store;
  return {
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
      route("GET /v1/sites/*/export", "sites", "export",
            [s](const HttpRequest& req, const std::string& id) {
              return site_export(*s, req, id);
            }),
  };
}

std::vector<ingest::StaticMount> web_mounts(const std::string& web_root) {
  return {{"/", web_root},
          {"/vendor/three/", web_root + "/node_modules/three"}};
}

std::string default_web_root() { return ARSCOUT_WEB_ROOT; }

}  // namespace arscout::viewer
