// The surface of oriented points: an implicit function blended from the
// points' tangent planes (IMLS), polygonised near the points only.
#include <algorithm>
#include <cmath>
#include <numeric>
#include <optional>
#include <stdexcept>
#include <unordered_map>
#include <unordered_set>

#include "arscout/engine/mesh.h"
#include "mesh/marching_tetrahedra.h"
#include "mesh/point_hash.h"
#include "mesh/surface_cleanup.h"

namespace arscout::engine {
namespace {

using mesh::GridIndex;

struct OrientedPoints {
  std::vector<Eigen::Vector3f> positions;
  std::vector<Eigen::Vector3f> normals;
  std::vector<std::array<std::uint8_t, 3>> colors;
};

OrientedPoints oriented(const std::vector<ColoredPoint>& points,
                        int min_support) {
  OrientedPoints out;
  for (const ColoredPoint& p : points) {
    const Eigen::Vector3f n(p.nx, p.ny, p.nz);
    if (!shown_at(p, min_support) || n.squaredNorm() < 0.25f) continue;
    out.positions.emplace_back(p.x, p.y, p.z);
    out.normals.push_back(n.normalized());
    out.colors.push_back({p.r, p.g, p.b});
  }
  return out;
}

// The cube range a column owns: lowest corners with x0 <= i * cell < x1.
struct ColumnCubes {
  std::int64_t x_lo, x_hi, y_lo, y_hi;  // inclusive
  bool owns(const GridIndex& i) const {
    return i[0] >= x_lo && i[0] <= x_hi && i[1] >= y_lo && i[1] <= y_hi;
  }
};

ColumnCubes column_cubes(const Eigen::Vector2d& lo, const Eigen::Vector2d& hi,
                         double cell) {
  // A bound meant on the grid is taken as on it: one column's upper bound
  // and its neighbour's lower bound, computed apart, may differ in the
  // last bit, and a cube would then belong to both or to neither (a seam).
  const auto first = [cell](double v) {
    const double steps = v / cell, nearest = std::round(steps);
    return static_cast<std::int64_t>(
        std::abs(steps - nearest) < 1e-6 ? nearest : std::ceil(steps));
  };
  return {first(lo.x()), first(hi.x()) - 1, first(lo.y()), first(hi.y()) - 1};
}

// The column's cubes near a point: every cube holding one, and those
// around it.
std::vector<GridIndex> cubes_near_points(const OrientedPoints& points,
                                         const ColumnCubes& column,
                                         double cell) {
  std::unordered_set<std::uint64_t> seeds;
  std::vector<GridIndex> seed_cubes;
  for (const Eigen::Vector3f& p : points.positions) {
    const GridIndex i = {static_cast<std::int64_t>(std::floor(p.x() / cell)),
                         static_cast<std::int64_t>(std::floor(p.y() / cell)),
                         static_cast<std::int64_t>(std::floor(p.z() / cell))};
    if (i[0] < column.x_lo - 1 || i[0] > column.x_hi + 1 ||
        i[1] < column.y_lo - 1 || i[1] > column.y_hi + 1)
      continue;
    if (seeds.insert(mesh::grid_key(i)).second) seed_cubes.push_back(i);
  }
  std::unordered_set<std::uint64_t> marked;
  std::vector<GridIndex> cubes;
  for (const GridIndex& s : seed_cubes)
    for (std::int64_t dz = -1; dz <= 1; ++dz)
      for (std::int64_t dy = -1; dy <= 1; ++dy)
        for (std::int64_t dx = -1; dx <= 1; ++dx) {
          const GridIndex c = {s[0] + dx, s[1] + dy, s[2] + dz};
          if (column.owns(c) && marked.insert(mesh::grid_key(c)).second)
            cubes.push_back(c);
        }
  // In grid order: the output does not depend on the points' order.
  std::sort(cubes.begin(), cubes.end());
  return cubes;
}

// Kolluri's IMLS: the weighted mean of the signed distances to the
// neighbours' tangent planes, Gaussian weights of width radius / 2.
class ImplicitFunction {
 public:
  ImplicitFunction(const OrientedPoints& points, double radius, int min_points)
      : points_(points),
        hash_(points.positions, radius),
        radius_(radius),
        inv_h2_(4.0 / (radius * radius)),
        min_points_(min_points) {}

  std::optional<float> at(const Eigen::Vector3d& x) const {
    double sum = 0, weights = 0;
    int count = 0;
    hash_.within(x, radius_, [&](std::uint32_t i, double d2) {
      const double w = std::exp(-d2 * inv_h2_);
      sum += w * points_.normals[i].cast<double>().dot(
                     x - points_.positions[i].cast<double>());
      weights += w;
      ++count;
    });
    if (count < min_points_ || weights <= 0) return std::nullopt;
    return static_cast<float>(sum / weights);
  }

  // Whether a point lies within `radius` (at most the blending radius).
  bool near_a_point(const Eigen::Vector3d& x, double radius) const {
    bool near = false;
    hash_.within(x, radius, [&](std::uint32_t, double) { near = true; });
    return near;
  }

  // The blended colour and normal at a surface vertex.
  void shade(const Eigen::Vector3d& x, std::array<std::uint8_t, 3>& color,
             Eigen::Vector3f& normal) const {
    Eigen::Vector3d rgb = Eigen::Vector3d::Zero(), n = Eigen::Vector3d::Zero();
    double weights = 0;
    hash_.within(x, radius_, [&](std::uint32_t i, double d2) {
      const double w = std::exp(-d2 * inv_h2_);
      const auto& c = points_.colors[i];
      rgb += w * Eigen::Vector3d(c[0], c[1], c[2]);
      n += w * points_.normals[i].cast<double>();
      weights += w;
    });
    if (weights > 0) rgb /= weights;
    for (int k = 0; k < 3; ++k)
      color[k] =
          static_cast<std::uint8_t>(std::clamp(rgb[k] + 0.5, 0.0, 255.0));
    normal = n.norm() > 0 ? Eigen::Vector3f(n.normalized().cast<float>())
                          : Eigen::Vector3f::UnitZ();
  }

 private:
  const OrientedPoints& points_;
  mesh::PointHash hash_;
  double radius_;
  double inv_h2_;
  int min_points_;
};

// `indices` without the triangles whose centre is farther than `radius`
// from every point.
std::vector<std::uint32_t> near_the_points(
    const std::vector<std::uint32_t>& indices,
    const std::vector<Eigen::Vector3d>& positions,
    const ImplicitFunction& function, double radius) {
  std::vector<std::uint32_t> kept;
  kept.reserve(indices.size());
  for (std::size_t t = 0; t + 2 < indices.size(); t += 3) {
    const Eigen::Vector3d centre =
        (positions[indices[t]] + positions[indices[t + 1]] +
         positions[indices[t + 2]]) /
        3;
    if (function.near_a_point(centre, radius))
      kept.insert(kept.end(), indices.begin() + t, indices.begin() + t + 3);
  }
  return kept;
}

}  // namespace

TexturedMesh mesh_surface(const std::vector<ColoredPoint>& points,
                          const Eigen::Vector2d& column_min,
                          const Eigen::Vector2d& column_max, double voxel,
                          const SurfaceOptions& options) {
  const double cell = options.cell > 0 ? options.cell : 2 * voxel;
  if (!(cell > 0)) throw std::invalid_argument("mesh_surface: no grid step");
  const OrientedPoints oriented_points = oriented(points, options.min_support);
  const ColumnCubes column = column_cubes(column_min, column_max, cell);
  const ImplicitFunction function(oriented_points, options.radius_cells * cell,
                                  options.min_points);
  std::unordered_map<std::uint64_t, std::optional<float>> values;
  const auto value = [&](const GridIndex& i) {
    const auto [it, added] = values.try_emplace(mesh::grid_key(i));
    if (added)
      it->second = function.at(Eigen::Vector3d(static_cast<double>(i[0]),
                                               static_cast<double>(i[1]),
                                               static_cast<double>(i[2])) *
                               cell);
    return it->second;
  };
  const mesh::IsoSurface iso = mesh::polygonise(
      cubes_near_points(oriented_points, column, cell), cell, value, 2 * cell);
  TexturedMesh out;
  const double trim = std::min(options.trim_cells, options.radius_cells) * cell;
  out.indices =
      trim > 0 ? near_the_points(iso.indices, iso.positions, function, trim)
               : iso.indices;
  out.positions.reserve(iso.positions.size());
  out.colors.resize(iso.positions.size());
  out.normals.resize(iso.positions.size());
  for (std::size_t v = 0; v < iso.positions.size(); ++v) {
    out.positions.push_back(iso.positions[v].cast<float>());
    function.shade(iso.positions[v], out.colors[v], out.normals[v]);
  }
  const double x_lo = static_cast<double>(column.x_lo) * cell;
  const double x_hi = static_cast<double>(column.x_hi + 1) * cell;
  const double y_lo = static_cast<double>(column.y_lo) * cell;
  const double y_hi = static_cast<double>(column.y_hi + 1) * cell;
  const float eps = static_cast<float>(cell * 1e-4);
  mesh::drop_small_pieces(out, options.min_piece_area_cells * cell * cell,
                          [&](const Eigen::Vector3f& p) {
                            return std::abs(p.x() - x_lo) < eps ||
                                   std::abs(p.x() - x_hi) < eps ||
                                   std::abs(p.y() - y_lo) < eps ||
                                   std::abs(p.y() - y_hi) < eps;
                          });
  return out;
}

}  // namespace arscout::engine
