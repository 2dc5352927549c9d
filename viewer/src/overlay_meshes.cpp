#include "overlay_meshes.h"

#include <algorithm>
#include <array>

#include <opencv2/imgcodecs.hpp>

#include "arscout/util/error.h"
#include "arscout/viewer/overlay.h"
#include "exporters/export_support.h"
#include "mesh_tileset.h"

namespace arscout::viewer {
namespace {

// True unless `box` is wholly behind the camera or wholly off one side of
// its picture (a conservative test: a box across the view's corner passes).
bool seen_by(const MeshBox& box, const ImageCamera& camera) {
  const engine::CameraIntrinsics& k = camera.intrinsics;
  int behind = 0, left = 0, right = 0, above = 0, below = 0;
  for (int corner = 0; corner < 8; ++corner) {
    const Eigen::Vector3d X((corner & 1) ? box.hi.x() : box.lo.x(),
                            (corner & 2) ? box.hi.y() : box.lo.y(),
                            (corner & 4) ? box.hi.z() : box.lo.z());
    const Eigen::Vector3d c = camera.R * X + camera.t;
    if (c.z() <= 0) {
      ++behind;
      continue;
    }
    const double u = k.fx * c.x() / c.z() + k.cx;
    const double v = k.fy * c.y() / c.z() + k.cy;
    left += u < 0;
    right += u >= k.width;
    above += v < 0;
    below += v >= k.height;
  }
  if (behind == 8) return false;
  // Corners behind the camera project anywhere: only the front ones decide,
  // and only when every corner is in front.
  if (behind > 0) return true;
  return left < 8 && right < 8 && above < 8 && below < 8;
}

// The distance from the camera's centre to the nearest point of `box`.
double distance_to(const MeshBox& box, const ImageCamera& camera) {
  const Eigen::Vector3d centre = -camera.R.transpose() * camera.t;
  const Eigen::Vector3d nearest = centre.cwiseMax(box.lo).cwiseMin(box.hi);
  return (nearest - centre).norm();
}

// The coarsest level of `tile` whose error, `distance` away, is at most
// kOverlayMaxPixelError pixels; the finest when none is.
std::size_t level_for(const engine::MeshTileEntry& tile, double distance,
                      double focal_px) {
  const double range = std::max(distance, 1e-3);
  for (std::size_t l = tile.levels.size(); l-- > 1;)
    if (tile.levels[l].geometric_error * focal_px / range <=
        kOverlayMaxPixelError)
      return l;
  return 0;
}

engine::TexturedMesh with_atlas(engine::GlbMesh glb, const SiteModel& model,
                                const engine::MeshTileEntry& tile) {
  if (!glb.image.empty()) {
    glb.mesh.atlas =
        cv::imdecode(cv::Mat(1, static_cast<int>(glb.image.size()), CV_8U,
                             const_cast<char*>(glb.image.data())),
                     cv::IMREAD_COLOR);
    if (glb.mesh.atlas.empty())
      throw util::Error(util::ErrorKind::kInternal,
                        "site " + model.site + ": mesh tile " + tile.tile +
                            ": its atlas (" + glb.image_mime +
                            ") does not decode");
  }
  return std::move(glb.mesh);
}

}  // namespace

std::vector<engine::TexturedMesh> meshes_seen_by(db::Store& store,
                                                 const SiteModel& model,
                                                 const ImageCamera& camera,
                                                 double focal_px) {
  std::vector<engine::TexturedMesh> meshes;
  for (const engine::MeshTileEntry& tile :
       formats::nonempty_mesh_tiles(model)) {
    // The coarsest level bounds the tile as the finest does (the levels
    // keep their borders) and is the cheapest to read.
    const std::size_t coarsest = tile.levels.size() - 1;
    engine::GlbMesh glb =
        formats::load_mesh_level(store, model, tile, coarsest);
    const MeshBox box = mesh_box(glb.mesh);
    if (box.empty() || !seen_by(box, camera)) continue;
    const std::size_t level =
        level_for(tile, distance_to(box, camera), focal_px);
    if (level != coarsest)
      glb = formats::load_mesh_level(store, model, tile, level);
    meshes.push_back(with_atlas(std::move(glb), model, tile));
  }
  return meshes;
}

}  // namespace arscout::viewer
