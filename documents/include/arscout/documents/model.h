// The model form: the attributes of /sites/{id}/model (docs/service.md),
// written by the engine service at each model version and read by the
// viewer, the exports, the CLI and the engine itself when it restarts.
// The point clouds travel as PLY blobs beside it.
#pragma once

#include <array>
#include <cstddef>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "arscout/documents/camera.h"
#include "arscout/documents/capture_status.h"
#include "arscout/documents/site.h"

namespace arscout::documents {

struct ModelCameraEntry {
  std::string id;
  Camera camera;  // refined, original-photo pixels
};

// A registered image: world-to-camera rotation (qvec, w x y z) and
// translation, the camera centre in the model's frame, and its geodetic
// position when the model is geo-registered.
struct ModelImageEntry {
  std::string id;
  std::string camera;  // a ModelCameraEntry id
  std::array<double, 4> qvec{1, 0, 0, 0};
  std::array<double, 3> tvec{0, 0, 0};
  std::array<double, 3> centre{0, 0, 0};
  std::optional<GeoPoint> geodetic;
  std::optional<bool> dense;  // in the published dense cloud (with one)
  // The component it belongs to (ModelComponentEntry::id); absent in
  // models written before components, which had one.
  std::optional<int> component;
};

// A separately reconstructed part of the site (docs/engine.md,
// "Components"): its id, registered images and sparse points.
struct ModelComponentEntry {
  int id = 0;
  std::size_t images = 0;
  std::size_t points = 0;
};

struct ModelStatistics {
  std::size_t captures = 0;
  std::size_t registered = 0;
  std::size_t pending = 0;
  std::size_t rejected = 0;
  std::size_t sparse_points = 0;
  std::size_t dense_points = 0;
  std::size_t depth_maps = 0;  // new in this version
  double mean_reprojection_px = 0;
};

// Seconds of the increment that made this version, by stage; the sparse
// stages summed over its captures.
struct ModelTimings {
  double decode_s = 0, undistort_s = 0, features_s = 0, matching_s = 0;
  double pose_s = 0, triangulation_s = 0, bundle_adjustment_s = 0;
  double sparse_s = 0, sweep_s = 0, filter_s = 0, fusion_s = 0;
  double total_s = 0;
};

struct ModelDocument {
  std::string site;
  bool geo_registered = false;  // frame "enu" when true, else "local"
  std::optional<GeoPoint> enu_origin;
  std::vector<ModelCameraEntry> cameras;
  std::vector<ModelImageEntry> images;  // in order of registration
  // Largest first; empty in models written before components.
  std::vector<ModelComponentEntry> components;
  std::map<std::string, CaptureStatus> capture_statuses;  // "captures"
  ModelStatistics statistics;
  std::vector<std::string> added;      // "increment": new in this version
  std::vector<std::string> withdrawn;  // and removed in it
  ModelTimings timings;
  std::string dense_state;  // "off", "pending" or "current"; "" = absent
  // The dense cloud's tiles, in the engine service's own form
  // (engine/service dense_tiles.h); null when absent.
  nlohmann::json dense_tiles;
  // The surface's tiles and their levels of detail (engine/service
  // mesh_tiles_of, docs/mesh.md); null when absent.
  nlohmann::json mesh_tiles;

  // The camera an image names; nullptr when none has its id.
  const ModelCameraEntry* camera_of(const ModelImageEntry& image) const;
  const ModelImageEntry* image(const std::string& id) const;
};

// Every field above under its docs/service.md name ("frame" derived from
// geo_registered; "dense_state", "dense_tiles" and "mesh_tiles" only when set).
nlohmann::json to_json(const ModelDocument& model);

// Reads a model document. Throws DocumentError naming the first bad field
// when a camera is not valid (validate_camera) or an image lacks its id,
// camera, qvec, tvec or centre; other fields read leniently.
ModelDocument model_from_json(const nlohmann::json& attrs);

}  // namespace arscout::documents
