// The scout's AR overlay (the paper's 3D-registered display): the site's
// current model drawn over one capture's photo through the capture's
// estimated pose and intrinsics: its points z-buffered and coloured by
// depth, or its textured surface (docs/mesh.md) as the photos painted it.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "arscout/db/store.h"
#include "arscout/engine/camera.h"
#include "arscout/engine/mesh.h"
#include "arscout/engine/ply.h"
#include "arscout/viewer/site_model.h"

namespace arscout::viewer {

// The pixel (original-photo pixels, OpenCV convention) where the world
// point X appears through the camera, with its lens distortion; nullopt
// behind the camera.
std::optional<Eigen::Vector2d> project(const ImageCamera& camera,
                                       const Eigen::Vector3d& X);

// What the overlay draws of the model.
enum class OverlayDraw {
  kPoints,  // the cloud (OverlayOptions::cloud), coloured by depth
  kMesh,    // the textured mesh, the nearest surface per pixel
};

struct OverlayOptions {
  int max_side = 1280;  // the output's long side (never above the photo's)
  OverlayDraw draw = OverlayDraw::kPoints;
  Cloud cloud = Cloud::kDense;  // with kPoints
  int radius = -1;              // splat half-size in output pixels; -1: by size
  double opacity = 0.55;        // of the drawn points over the photo
  // Fused points measured by fewer depth maps are not drawn (shown_at):
  // the scout sees the confident cloud only. 0 draws every point.
  int min_support = engine::kConfidentSupport;
};

// Draws `points` over `photo` (BGR, original size) seen by `camera`: each
// point shown at the options' min_support is projected with project(),
// splatted, z-buffered, and coloured by
// its depth (turbo colour map, near red, far blue, over the 2nd-98th
// percentile of the drawn depths). Returns the drawn image at the options'
// size.
cv::Mat draw_overlay(const cv::Mat& photo, const ImageCamera& camera,
                     const std::vector<engine::ColoredPoint>& points,
                     const OverlayOptions& options);

// Draws the textured `meshes` (site frame) over `photo` (BGR, original
// size) seen by `camera`: each rendered through the camera's pinhole at
// the options' size (engine::render_mesh), the nearest surface kept per
// pixel, warped by the camera's lens distortion, and blended at the
// options' opacity where a surface is seen (elsewhere the photo).
cv::Mat draw_mesh_overlay(const cv::Mat& photo, const ImageCamera& camera,
                          const std::vector<engine::TexturedMesh>& meshes,
                          const OverlayOptions& options);

// The overlay of capture `capture` as JPEG bytes, from the store: its
// photo, its site's current model (with kMesh the mesh tiles the camera
// sees, each at the coarsest level of detail whose geometric error is
// under a pixel of the output). Throws util::Error kNotFound when the
// capture is unknown or not (yet) registered in its site's model, or when
// kMesh is asked of a site without a mesh.
std::string overlay_jpeg(db::Store& store, const std::string& capture,
                         const OverlayOptions& options);

}  // namespace arscout::viewer
