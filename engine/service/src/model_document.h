// The /sites/{id}/model document (documents/model.h, docs/service.md), from
// a Model: everything a viewer or an export needs except the point clouds,
// which travel as PLY blobs.
#pragma once

#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "arscout/documents/model.h"
#include "arscout/engine/dense_reconstruction.h"
#include "arscout/engine/reconstruction.h"

namespace arscout::engine::service {

using Json = nlohmann::json;

// What one increment did, for the model's statistics and timings.
struct IncrementReport {
  std::vector<std::string> added;      // captures new in this increment
  std::vector<std::string> withdrawn;  // captures removed in it
  StageTimings sparse;                 // summed over the added captures
  DenseUpdate dense;
  size_t dense_points = 0;
  double total_s = 0;
};

// `dense_views`, with a dense cloud: the registered views it covers (key
// views with a depth map, and views those cover), so that each image entry
// says whether its view is in the published cloud ("dense").
documents::ModelDocument model_document(
    const std::string& site, const Model& model,
    const std::vector<CaptureState>& captures, const IncrementReport& report,
    const std::set<std::string>* dense_views = nullptr);

// The binary PLY of the model's sparse points (encode_ply's layout).
std::string sparse_ply(const Model& model);

}  // namespace arscout::engine::service
