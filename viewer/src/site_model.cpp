#include "arscout/viewer/site_model.h"
#include "arscout/util/error.h"

#include <Eigen/Geometry>

#include "arscout/db/errors.h"
#include "arscout/db/path.h"
#include "arscout/documents/document_error.h"
#include "arscout/documents/site.h"
#include "arscout/engine/service.h"

namespace arscout::viewer {
namespace {

using db::ErrorCode;
using db::StoreError;

std::string blob_of(const db::Document& doc, const std::string& name) {
  auto it = doc.blobs.find(name);
  return it == doc.blobs.end() ? std::string() : it->second;
}

documents::ModelDocument read_model_document(const db::Document& doc,
                                             const std::string& site) {
  try {
    return documents::model_from_json(doc.attrs);
  } catch (const documents::DocumentError& e) {
    throw util::Error(util::ErrorKind::kInternal,
                      "the model of site " + site + " is damaged: " + e.what());
  }
}

// The site whose model `site` has: `site` itself, or the one it grew
// into. Throws kNotFound for a site that has no document.
std::string model_holder(db::Store& store, const std::string& site) {
  std::string at = site;
  for (int hops = 0; hops < 64; ++hops) {  // a bounded chain of merges
    const auto doc = store.get("/sites/" + at);
    if (!doc) {
      if (at == site)
        throw util::Error(util::ErrorKind::kNotFound, "no site " + site);
      return at;
    }
    std::string next;
    try {
      next = documents::site_from_json(doc->attrs, at).merged_into;
    } catch (const documents::DocumentError& e) {
      throw util::Error(
          util::ErrorKind::kInternal,
          "the document of site " + at + " is damaged: " + e.what());
    }
    if (next.empty() || next.find('/') != std::string::npos) return at;
    at = next;
  }
  return at;
}

}  // namespace

SiteModel load_site_model(db::Store& store, const std::string& requested) {
  if (requested.empty() || requested.find('/') != std::string::npos)
    throw util::Error(util::ErrorKind::kInvalidArgument,
                      "'" + requested + "' is not a site id");
  db::validate_path("/sites/" + requested + "/model");
  const std::string site = model_holder(store, requested);
  const auto doc = store.get("/sites/" + site + "/model");
  if (!doc)
    throw util::Error(util::ErrorKind::kNotFound,
                      "site " + site + " has no model yet");
  SiteModel model;
  model.site = site;
  model.version = doc->version;
  model.updated_us = doc->updated_us;
  model.attrs = doc->attrs;
  model.document = read_model_document(*doc, site);
  model.sparse_blob = blob_of(*doc, "sparse");
  model.dense_blobs = engine::dense_cloud_blobs(*doc);
  return model;
}

engine::Model load_full_model(db::Store& store, const SiteModel& model) {
  const auto state = engine::load_site_reconstruction(store, model.site);
  if (!state)
    throw util::Error(util::ErrorKind::kNotFound,
                      "site " + model.site + " has no engine state");
  engine::Model full = state->model();
  std::vector<std::string> stated, restored;
  for (const documents::ModelImageEntry& image : model.document.images)
    stated.push_back(image.id);
  for (const engine::ModelImage& image : full.images)
    restored.push_back(image.id);
  if (stated != restored)
    throw util::Error(util::ErrorKind::kUnavailable,
                      "site " + model.site +
                          ": the engine committed while the model was read; "
                          "try again");
  return full;
}

engine::Model load_consistent_full_model(db::Store& store,
                                         const std::string& site,
                                         SiteModel* model) {
  for (int attempt = 0;; ++attempt) {
    *model = load_site_model(store, site);
    try {
      return load_full_model(store, *model);
    } catch (const util::Error& e) {  // the engine committed meanwhile
      if (e.kind() != util::ErrorKind::kUnavailable || attempt == 4) throw;
    } catch (const StoreError& e) {
      if (e.code() != ErrorCode::kUnavailable || attempt == 4) throw;
    }
  }
}

std::vector<engine::ColoredPoint> load_cloud(db::Store& store,
                                             const SiteModel& model,
                                             Cloud which) {
  if (which == Cloud::kDense && !model.dense_blobs.empty())
    return engine::load_dense_cloud(store, model.dense_blobs);
  if (model.sparse_blob.empty()) return {};
  return engine::decode_ply(store.get_blob(model.sparse_blob));
}

const char* cloud_name(const SiteModel& model, Cloud which) {
  return which == Cloud::kDense && !model.dense_blobs.empty() ? "dense"
                                                              : "sparse";
}

std::optional<ImageCamera> image_camera(const SiteModel& model,
                                        const std::string& capture) {
  const documents::ModelImageEntry* image = model.document.image(capture);
  if (!image) return std::nullopt;
  const documents::ModelCameraEntry* entry = model.document.camera_of(*image);
  if (!entry)
    throw util::Error(util::ErrorKind::kInternal,
                      "model of " + model.site + ": image " + capture +
                          " names an unknown camera");
  ImageCamera camera;
  camera.id = capture;
  camera.intrinsics = entry->camera;
  const auto& q = image->qvec;
  camera.R = Eigen::Quaterniond(q[0], q[1], q[2], q[3]).toRotationMatrix();
  camera.t = Eigen::Vector3d(image->tvec[0], image->tvec[1], image->tvec[2]);
  return camera;
}

}  // namespace arscout::viewer
