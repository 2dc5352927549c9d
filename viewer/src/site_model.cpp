#include "arscout/viewer/site_model.h"

#include <Eigen/Geometry>

#include "arscout/db/errors.h"
#include "arscout/db/path.h"
#include "arscout/engine/service.h"

namespace arscout::viewer {
namespace {

using db::ErrorCode;
using db::StoreError;

std::string blob_of(const db::Document& doc, const std::string& name) {
  auto it = doc.blobs.find(name);
  return it == doc.blobs.end() ? std::string() : it->second;
}

engine::CameraIntrinsics intrinsics_of(const Json& c) {
  engine::CameraIntrinsics k;
  k.width = c.at("width");
  k.height = c.at("height");
  k.fx = c.at("fx");
  k.fy = c.at("fy");
  k.cx = c.at("cx");
  k.cy = c.at("cy");
  const std::vector<double> d =
      c.value("distortion", std::vector<double>(5, 0.0));
  if (d.size() == 5) {
    k.k1 = d[0];
    k.k2 = d[1];
    k.p1 = d[2];
    k.p2 = d[3];
    k.k3 = d[4];
  }
  k.source = c.value("source", "calibrated");
  return k;
}

}  // namespace

SiteModel load_site_model(db::Store& store, const std::string& site) {
  if (site.empty() || site.find('/') != std::string::npos)
    throw StoreError(ErrorCode::kInvalidArgument,
                     "'" + site + "' is not a site id");
  const std::string path = "/sites/" + site + "/model";
  db::validate_path(path);
  const auto doc = store.get(path);
  if (!doc)
    throw StoreError(ErrorCode::kNotFound,
                     "site " + site + " has no model yet");
  SiteModel model;
  model.site = site;
  model.version = doc->version;
  model.updated_us = doc->updated_us;
  model.attrs = doc->attrs;
  model.sparse_blob = blob_of(*doc, "sparse");
  model.dense_blobs = engine::dense_cloud_blobs(*doc);
  return model;
}

engine::Model load_full_model(db::Store& store, const SiteModel& model) {
  const auto state = engine::load_site_reconstruction(store, model.site);
  if (!state)
    throw StoreError(ErrorCode::kNotFound,
                     "site " + model.site + " has no engine state");
  engine::Model full = state->model();
  std::vector<std::string> stated, restored;
  for (const Json& image : model.attrs.value("images", Json::array()))
    stated.push_back(image.at("id"));
  for (const engine::ModelImage& image : full.images)
    restored.push_back(image.id);
  if (stated != restored)
    throw StoreError(ErrorCode::kUnavailable,
                     "site " + model.site +
                         ": the engine committed while the model was read; "
                         "try again");
  return full;
}

std::vector<engine::ColoredPoint> load_cloud(db::Store& store,
                                             const SiteModel& model,
                                             Cloud which) {
  if (which == Cloud::kDense && !model.dense_blobs.empty())
    return engine::load_dense_cloud(store, model.dense_blobs);
  if (model.sparse_blob.empty()) return {};
  return engine::decode_ply(store.get_blob(model.sparse_blob));
}

std::optional<ImageCamera> image_camera(const SiteModel& model,
                                        const std::string& capture) {
  const Json& cameras = model.attrs.at("cameras");
  for (const Json& image : model.attrs.value("images", Json::array())) {
    if (image.at("id") != capture) continue;
    ImageCamera camera;
    camera.id = capture;
    // "camera" names an entry of "cameras" by its id.
    for (const Json& c : cameras)
      if (c.at("id") == image.at("camera"))
        camera.intrinsics = intrinsics_of(c);
    if (camera.intrinsics.width <= 0)
      throw db::StoreError(db::ErrorCode::kInternal,
                           "model of " + model.site + ": image " + capture +
                               " names an unknown camera");
    const auto q = image.at("qvec").get<std::array<double, 4>>();
    camera.R = Eigen::Quaterniond(q[0], q[1], q[2], q[3]).toRotationMatrix();
    const auto t = image.at("tvec").get<std::array<double, 3>>();
    camera.t = Eigen::Vector3d(t[0], t[1], t[2]);
    return camera;
  }
  return std::nullopt;
}

}  // namespace arscout::viewer
