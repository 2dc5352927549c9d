// Ray casting of the synthetic site. A block scene has hundreds of quads, of
// which a pixel can see a handful: each view splits the image into tiles and
// gives every tile the quads that overlap its pyramid of rays, and each ray
// is tested against its tile's quads alone. Culling only drops quads no ray
// of the tile can hit and keeps the site's order, so the nearest hit (ties
// go to the earlier quad) and hence every pixel are what testing all quads
// would give.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include <Eigen/Dense>
#include <opencv2/core.hpp>

#include "arscout/engine/synthetic_site.h"

namespace arscout::engine::synthetic {
namespace {

// A quad prepared for one view.
struct Target {
  Eigen::Vector3d corner;
  Eigen::Vector3d normal;  // edge_u x edge_v, not unit
  // Rows of the inverse of [edge_u edge_v] on the plane: the dot product
  // with (point - corner) gives s and t.
  Eigen::Vector3d dual_u;
  Eigen::Vector3d dual_v;
  double numerator = 0;  // normal . (corner - camera centre)
  double length_u = 0;
  double length_v = 0;
  Texture texture = Texture::kNoise;
  uint32_t seed = 0;
  float brightness = 1;
  int index = 0;  // in Site::quads
};

// A fixed light direction gives each orientation its own constant
// brightness: box faces stand apart, and nothing depends on the viewer. The
// absolute value makes the result independent of the quad's winding.
float brightness_of(const Eigen::Vector3d& unit_normal) {
  const Eigen::Vector3d light = Eigen::Vector3d(0.4, -0.6, 0.7).normalized();
  return static_cast<float>(0.55 + 0.45 * std::abs(unit_normal.dot(light)));
}

// A target's four corners, in camera coordinates.
using Corners = std::array<Eigen::Vector3d, 4>;

std::vector<Target> prepare(const Site& site, const PinholeView& view,
                            std::vector<Corners>* corners) {
  const Eigen::Vector3d eye = view.centre();
  std::vector<Target> targets;
  for (const Quad& quad : site.quads) {
    const Eigen::Vector3d normal = quad.edge_u.cross(quad.edge_v);
    const double area2 = normal.squaredNorm();
    if (!(area2 > 0)) continue;  // degenerate: no plane to hit
    Target target;
    target.corner = quad.corner;
    target.normal = normal;
    target.dual_u = quad.edge_v.cross(normal) / area2;
    target.dual_v = normal.cross(quad.edge_u) / area2;
    target.numerator = normal.dot(quad.corner - eye);
    target.length_u = quad.edge_u.norm();
    target.length_v = quad.edge_v.norm();
    target.texture = quad.texture;
    target.seed = quad.seed;
    target.brightness = brightness_of(normal / std::sqrt(area2));
    target.index = static_cast<int>(&quad - site.quads.data());
    targets.push_back(target);
    const Eigen::Vector3d far = quad.corner + quad.edge_u + quad.edge_v;
    corners->push_back({view.R * quad.corner + view.t,
                        view.R * (quad.corner + quad.edge_u) + view.t,
                        view.R * (quad.corner + quad.edge_v) + view.t,
                        view.R * far + view.t});
  }
  return targets;
}

// The rays through pixel positions [u0, u1] x [v0, v1] fill the cone of
// camera points X with Z > 0 and u0 <= k0.X / Z <= u1, v0 <= k1.X / Z <= v1
// (k0, k1 the rows of K, whose last row is (0, 0, 1)): the intersection of
// five half-spaces through the centre. A convex quad whose four corners all
// lie outside one of them cannot meet the cone.
class RayPyramid {
 public:
  RayPyramid(const Eigen::Matrix3d& K, double u0, double u1, double v0,
             double v1) {
    const Eigen::Vector3d k0 = K.row(0).transpose();
    const Eigen::Vector3d k1 = K.row(1).transpose();
    const Eigen::Vector3d z = Eigen::Vector3d::UnitZ();
    planes_ = {z, k0 - u0 * z, u1 * z - k0, k1 - v0 * z, v1 * z - k1};
  }

  bool may_meet(const Corners& corners) const {
    for (const Eigen::Vector3d& plane : planes_) {
      bool outside = true;
      for (const Eigen::Vector3d& corner : corners) {
        outside = outside && plane.dot(corner) <= 0;
      }
      if (outside) return false;
    }
    return true;
  }

 private:
  std::array<Eigen::Vector3d, 5> planes_;
};

struct Hit {
  double depth = std::numeric_limits<double>::infinity();
  const Target* target = nullptr;
  double s = 0;
  double t = 0;
};

// `direction` has unit camera z, so the ray parameter is the camera depth.
Hit cast(const std::vector<Target>& targets, const Eigen::Vector3d& eye,
         const Eigen::Vector3d& direction) {
  // Rejects hits at (or behind) the centre itself, where a quad through the
  // camera would otherwise cover the whole image.
  constexpr double kMinDepth = 1e-9;
  Hit hit;
  for (const Target& target : targets) {
    const double denominator = target.normal.dot(direction);
    if (denominator == 0) continue;  // ray parallel to the plane
    const double depth = target.numerator / denominator;
    if (!(depth > kMinDepth) || depth >= hit.depth) continue;
    const Eigen::Vector3d offset = eye + depth * direction - target.corner;
    const double s = target.dual_u.dot(offset);
    const double t = target.dual_v.dot(offset);
    if (s < 0 || s > 1 || t < 0 || t > 1) continue;
    hit = {depth, &target, s, t};
  }
  return hit;
}

// Light blue sky, BGR in [0, 1].
const cv::Vec3f kSky(235 / 255.f, 206 / 255.f, 170 / 255.f);

cv::Vec3f shade(const Hit& hit) {
  if (hit.target == nullptr) return kSky;
  const Target& target = *hit.target;
  return texture_colour(target.texture, target.seed, hit.s * target.length_u,
                        hit.t * target.length_v) *
         target.brightness;
}

// Square blocks of pixels that share one list of candidate quads: small
// enough that a tile sees few quads, large enough that building the lists
// costs little next to casting.
constexpr int kTile = 32;

// Everything one view needs per ray, fixed at construction: read-only
// afterwards, so rows can be cast concurrently.
class Caster {
 public:
  Caster(const Site& site, const PinholeView& view, int supersampling)
      : eye_(view.centre()),
        camera_to_world_(view.R.transpose()),
        k_inverse_(view.K.inverse()),
        width_(view.size.width),
        columns_((view.size.width + kTile - 1) / kTile),
        supersampling_(supersampling) {
    std::vector<Corners> corners;
    const std::vector<Target> targets = prepare(site, view, &corners);
    const int rows = (view.size.height + kTile - 1) / kTile;
    tiles_.resize(static_cast<size_t>(rows) * columns_);
    // Without the last row (0, 0, 1) of the contract, K's rows do not bound
    // the rays: every tile keeps every quad.
    if (view.K.row(2) != Eigen::RowVector3d(0, 0, 1)) {
      for (auto& tile : tiles_) tile = targets;
      return;
    }
    for (int row = 0; row < rows; ++row) {
      for (int column = 0; column < columns_; ++column) {
        // Sub-pixel rays stay within half a pixel of the tile's pixel
        // centres; another half pixel keeps rounding from mattering.
        const RayPyramid pyramid(
            view.K, column * kTile - 1.0,
            std::min((column + 1) * kTile, view.size.width), row * kTile - 1.0,
            std::min((row + 1) * kTile, view.size.height));
        auto& tile = tiles_[static_cast<size_t>(row) * columns_ + column];
        for (size_t i = 0; i < targets.size(); ++i) {
          if (pyramid.may_meet(corners[i])) tile.push_back(targets[i]);
        }
      }
    }
  }

  void row(int y, cv::Vec3b* colour, float* depth) const {
    const size_t first_tile = static_cast<size_t>(y / kTile) * columns_;
    for (int x = 0; x < width_; ++x) {
      const std::vector<Target>& targets = tiles_[first_tile + x / kTile];
      const Hit centre = cast(targets, eye_, direction(x, y));
      depth[x] = centre.target ? static_cast<float>(centre.depth) : 0.f;
      colour[x] = pixel_colour(targets, x, y);
    }
  }

 private:
  Eigen::Vector3d direction(double x, double y) const {
    const Eigen::Vector3d camera = k_inverse_ * Eigen::Vector3d(x, y, 1);
    return camera_to_world_ * (camera / camera.z());
  }

  // Sub-pixel rays on a regular grid centred in the pixel.
  cv::Vec3b pixel_colour(const std::vector<Target>& targets, int x,
                         int y) const {
    const double step = 1.0 / supersampling_;
    const double first = 0.5 * step - 0.5;
    cv::Vec3f sum(0, 0, 0);
    for (int j = 0; j < supersampling_; ++j) {
      for (int i = 0; i < supersampling_; ++i) {
        const Eigen::Vector3d ray =
            direction(x + first + i * step, y + first + j * step);
        sum += shade(cast(targets, eye_, ray));
      }
    }
    const float scale = 255.f / (supersampling_ * supersampling_);
    return {cv::saturate_cast<uchar>(sum[0] * scale),
            cv::saturate_cast<uchar>(sum[1] * scale),
            cv::saturate_cast<uchar>(sum[2] * scale)};
  }

  Eigen::Vector3d eye_;
  Eigen::Matrix3d camera_to_world_;
  Eigen::Matrix3d k_inverse_;
  int width_;
  int columns_;
  int supersampling_;
  // Row-major, columns_ per row: the quads each tile's rays may hit, in the
  // site's order.
  std::vector<std::vector<Target>> tiles_;
};

}  // namespace

std::vector<int> quads_seen(const Site& site, const PinholeView& view,
                            int step_px) {
  if (step_px < 1) throw std::invalid_argument("quads_seen: step_px < 1");
  std::vector<Corners> corners;
  const std::vector<Target> targets = prepare(site, view, &corners);
  const Eigen::Matrix3d to_world = view.R.transpose();
  const Eigen::Matrix3d k_inverse = view.K.inverse();
  std::vector<int> rays(site.quads.size(), 0);
  for (int y = step_px / 2; y < view.size.height; y += step_px)
    for (int x = step_px / 2; x < view.size.width; x += step_px) {
      const Eigen::Vector3d camera = k_inverse * Eigen::Vector3d(x, y, 1);
      const Hit hit =
          cast(targets, view.centre(), to_world * (camera / camera.z()));
      if (hit.target) ++rays[hit.target->index];
    }
  return rays;
}

Rendering render(const Site& site, const PinholeView& view, int supersampling) {
  if (supersampling < 1) {
    throw std::invalid_argument("render: supersampling must be at least 1");
  }
  if (view.size.width <= 0 || view.size.height <= 0) {
    throw std::invalid_argument("render: empty image size");
  }
  Caster caster(site, view, supersampling);
  Rendering out;
  out.bgr.create(view.size, CV_8UC3);
  out.depth.create(view.size, CV_32F);
  // Each row is written by exactly one task from read-only state, so the
  // result does not depend on how rows are split among threads.
  cv::parallel_for_(cv::Range(0, view.size.height), [&](const cv::Range& rows) {
    for (int y = rows.start; y < rows.end; ++y) {
      caster.row(y, out.bgr.ptr<cv::Vec3b>(y), out.depth.ptr<float>(y));
    }
  });
  return out;
}

}  // namespace arscout::engine::synthetic
