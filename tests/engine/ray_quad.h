// An intersection of a pixel's ray with a quad of the synthetic renderer,
// solved independently of the renderer, for the renderer's tests.
#pragma once

#include <cmath>
#include <optional>

#include <Eigen/Dense>

#include "arscout/engine/synthetic_site.h"

namespace arscout::engine::synthetic {

// The depth at which the ray through pixel (x, y) meets the quad, solving
// corner + s edge_u + t edge_v = eye + depth ray; none when it misses or
// meets it behind the camera.
inline std::optional<double> ray_quad_depth(const PinholeView& view, double x,
                                            double y, const Quad& quad) {
  Eigen::Vector3d ray = view.K.inverse() * Eigen::Vector3d(x, y, 1);
  ray = view.R.transpose() * (ray / ray.z());
  Eigen::Matrix3d system;
  system << quad.edge_u, quad.edge_v, -ray;
  if (std::abs(system.determinant()) < 1e-12) return std::nullopt;
  const Eigen::Vector3d st_depth =
      system.partialPivLu().solve(view.centre() - quad.corner);
  const double s = st_depth(0), t = st_depth(1), depth = st_depth(2);
  if (s < 0 || s > 1 || t < 0 || t > 1 || depth <= 0) return std::nullopt;
  return depth;
}

}  // namespace arscout::engine::synthetic
