// The dense model of one site, grown one increment at a time alongside the
// sparse Reconstruction: every newly registered capture becomes a key view
// and gets one plane-sweep depth map with its two best neighbours; depth
// maps are checked against each other (a depth survives only when another
// map agrees), and agreeing pixels are fused into a voxel-de-duplicated,
// coloured point cloud in the site frame. Earlier depth maps are never
// recomputed; when bundle adjustment moves cameras, the cloud is re-fused
// from the stored depth maps (cheap: no sweeping).
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "arscout/engine/dense.h"
#include "arscout/engine/reconstruction.h"

namespace arscout::engine {

struct DenseOptions {
  int long_side = 640;  // dense working resolution (long side, pixels)
  PlaneSweepOptions sweep;
  ConsistencyOptions consistency;
  int neighbours = 2;  // per key view: the paper's triplets
  // A neighbour's baseline, as the median angle between the two cameras'
  // rays to the sparse points they share: too small measures depth poorly,
  // too large matches poorly.
  double min_angle_deg = 2;
  double max_angle_deg = 35;
  // Each new depth map is checked against the maps of this many views that
  // share the most sparse points with it (both directions).
  int consistency_partners = 4;
  // Voxel edge in site units; 0 takes 1.5 pixel footprints at the median
  // depth of the first depth map.
  double voxel_size = 0;
  // A camera that moved more than this share of a voxel (or turned by the
  // equivalent angle) since its depth map was fused triggers a re-fusion.
  double refuse_fraction = 0.25;
};

struct DenseUpdate {
  std::vector<std::string> new_depth_maps;  // key views swept this time
  std::vector<std::string> skipped;         // registered, but no neighbour
  bool refused = false;                     // cloud rebuilt from all maps
  size_t points = 0;                        // in the fused cloud
  double sweep_s = 0;
  double filter_s = 0;
  double fusion_s = 0;
};

// The encoded photo (JPEG or PNG) of a capture, by id. Throws when missing.
using ImageSource = std::function<std::string(const std::string& id)>;

class DenseReconstruction {
 public:
  explicit DenseReconstruction(DenseOptions options = {});
  ~DenseReconstruction();
  DenseReconstruction(DenseReconstruction&&) noexcept;
  DenseReconstruction& operator=(DenseReconstruction&&) noexcept;

  // Brings the dense model up to `model`: sweeps the registered captures
  // that have no depth map yet, filters, fuses; drops the maps of captures
  // no longer in the model. `progress`, when set, is told about each sweep.
  DenseUpdate update(
      const Model& model, const ImageSource& images,
      const std::function<void(const std::string&)>& progress = {});

  std::vector<ColoredPoint> points() const;
  // The stored maps, filtered: only pixels another map agrees with.
  std::vector<DepthMap> filtered_depth_maps() const;
  // As swept, before the consistency filter.
  const DepthMap* raw_depth_map(const std::string& id) const;
  double voxel_size() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// One key view's depth map straight from a sparse model: the key and its
// best neighbours are decoded, undistorted and swept, without filtering.
// Throws std::invalid_argument when `key_id` is not registered or has no
// usable neighbour.
DepthMap compute_key_depth_map(const Model& model, const std::string& key_id,
                               const ImageSource& images,
                               const DenseOptions& options = {});

// A registered capture's photo as the dense stage sees it: decoded at
// `long_side`, undistorted; `K` receives the matching pinhole matrix.
// Throws std::invalid_argument when `id` is not registered.
cv::Mat load_undistorted(const Model& model, const std::string& id,
                         const ImageSource& images, int long_side,
                         Eigen::Matrix3d* K);

}  // namespace arscout::engine
