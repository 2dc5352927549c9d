// The street scene and the cameras that photograph it.
#include <stdexcept>
#include <vector>

#include <Eigen/Dense>

#include "arscout/engine/synthetic_site.h"

namespace arscout::engine::synthetic {
namespace {

Quad quad(const Eigen::Vector3d& corner, const Eigen::Vector3d& edge_u,
          const Eigen::Vector3d& edge_v, Texture texture) {
  return {corner, edge_u, edge_v, texture, 0};
}

// Edges are ordered so that edge_u x edge_v points out of the box; edge_v
// is up on the sides so textures stand upright.
void add_box(std::vector<Quad>& quads) {
  const Eigen::Vector3d up(0, 0, 1.2);
  quads.push_back(quad({-1.5, 6, 0}, {2, 0, 0}, up, Texture::kNoise));
  quads.push_back(quad({0.5, 7.5, 0}, {-2, 0, 0}, up, Texture::kNoise));
  quads.push_back(quad({-1.5, 7.5, 0}, {0, -1.5, 0}, up, Texture::kNoise));
  quads.push_back(quad({0.5, 6, 0}, {0, 1.5, 0}, up, Texture::kNoise));
  quads.push_back(
      quad({-1.5, 6, 1.2}, {2, 0, 0}, {0, 1.5, 0}, Texture::kNoise));
}

}  // namespace

Site street_site(uint32_t seed) {
  Site site;
  auto& quads = site.quads;
  // Facade facing south (-y), bricks laid along x.
  quads.push_back(quad({-8, 10, 0}, {16, 0, 0}, {0, 0, 8}, Texture::kBrick));
  quads.push_back(quad({-8, -2, 0}, {16, 0, 0}, {0, 12, 0}, Texture::kAsphalt));
  // Side wall facing west (-x).
  quads.push_back(quad({6, 10, 0}, {0, -6, 0}, {0, 0, 6}, Texture::kPlaster));
  add_box(quads);
  // Distinct seeds per quad so that the box faces do not repeat each other;
  // the textures hash the seed, so consecutive values are unrelated.
  for (size_t i = 0; i < quads.size(); ++i) {
    quads[i].seed = seed * 16u + static_cast<uint32_t>(i);
  }
  return site;
}

PinholeView look_at(const Eigen::Vector3d& centre,
                    const Eigen::Vector3d& target, const Eigen::Matrix3d& K,
                    cv::Size size) {
  const Eigen::Vector3d forward = target - centre;
  if (!(forward.norm() > 0)) {
    throw std::invalid_argument("look_at: centre and target coincide");
  }
  const Eigen::Vector3d z = forward.normalized();
  const Eigen::Vector3d horizontal = z.cross(Eigen::Vector3d::UnitZ());
  // sin of the angle to the vertical: below this the roll is undefined.
  if (horizontal.norm() < 1e-9) {
    throw std::invalid_argument("look_at: viewing direction is vertical");
  }
  const Eigen::Vector3d x = horizontal.normalized();
  PinholeView view;
  view.K = K;
  view.R.row(0) = x;
  view.R.row(1) = z.cross(x);  // down in the world, as x is horizontal
  view.R.row(2) = z;
  view.t = -view.R * centre;
  view.size = size;
  return view;
}

std::vector<PinholeView> street_cameras(int count, cv::Size size,
                                        double focal_px) {
  if (count < 1) {
    throw std::invalid_argument("street_cameras: count must be at least 1");
  }
  Eigen::Matrix3d K;
  K << focal_px, 0, (size.width - 1) / 2.0, 0, focal_px,
      (size.height - 1) / 2.0, 0, 0, 1;
  const Eigen::Vector3d target(0, 10, 2.5);
  std::vector<PinholeView> views;
  for (int i = 0; i < count; ++i) {
    const double x = count == 1 ? 0.0 : -2 + 4.0 * i / (count - 1);
    views.push_back(look_at({x, 0, 1.6}, target, K, size));
  }
  return views;
}

}  // namespace arscout::engine::synthetic
