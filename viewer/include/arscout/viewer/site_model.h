// A site's current model as the store holds it, for everything that reads
// models back out: overlays, exports, the viewer's extra endpoints.
//
// The model document (/sites/{id}/model, docs/service.md) has the cameras,
// the poses and the point clouds as PLY blobs; the engine state
// (/sites/{id}/engine) also has every keypoint and track, which a COLMAP
// export needs.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "arscout/db/store.h"
#include "arscout/documents/model.h"
#include "arscout/engine/camera.h"
#include "arscout/engine/ply.h"
#include "arscout/engine/reconstruction.h"

namespace arscout::viewer {

using Json = nlohmann::json;

// The model document of one site.
struct SiteModel {
  std::string site;
  std::int64_t version = 0;     // the model version (the document's version)
  std::int64_t updated_us = 0;  // when it was committed (Unix microseconds)
  Json attrs;                   // the document's attributes
  documents::ModelDocument document;  // the same, read (documents/model.h)
  std::string sparse_blob;            // SHA-256 of the sparse PLY ("" if none)
  // SHA-256 of each PLY that holds the dense cloud: its tiles (none before
  // the first dense phase; engine::dense_cloud_blobs).
  std::vector<std::string> dense_blobs;
};

// The model of site `requested`, or of the site it grew into (its document
// says `merged_into`; followed through later merges): then `SiteModel::site`
// names that one. Throws util::Error kNotFound ("no site S") for a site
// that was never placed, kNotFound ("site S has no model yet") when there
// is no model document yet, kInvalidArgument for a site id that is not a
// path segment, kInternal when the document does not hold the model form.
SiteModel load_site_model(db::Store& store, const std::string& requested);

// The full model (keypoints and tracks included), restored from the
// engine state that was committed with `model`. Throws util::Error
// kUnavailable when the state and the document disagree on the registered
// images (the engine committed between the two reads: read both again).
engine::Model load_full_model(db::Store& store, const SiteModel& model);

// load_site_model then load_full_model, both read again (up to 5 times)
// while the engine commits between the two reads; *model is the document
// the returned model goes with.
engine::Model load_consistent_full_model(db::Store& store,
                                         const std::string& site,
                                         SiteModel* model);

enum class Cloud { kDense, kSparse };

// The dense cloud when the model has one (and `which` is kDense), else the
// sparse one; in the model's frame.
std::vector<engine::ColoredPoint> load_cloud(db::Store& store,
                                             const SiteModel& model,
                                             Cloud which = Cloud::kDense);

// "dense" when `which` is kDense and the model has a dense cloud, else
// "sparse": the cloud load_cloud gives.
const char* cloud_name(const SiteModel& model, Cloud which);

// One registered image's camera as the model document states it:
// intrinsics in original-photo pixels, world-to-camera R and t.
struct ImageCamera {
  std::string id;
  engine::CameraIntrinsics intrinsics;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
};

// nullopt when `capture` is not registered in the model.
std::optional<ImageCamera> image_camera(const SiteModel& model,
                                        const std::string& capture);

}  // namespace arscout::viewer
