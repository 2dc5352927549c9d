// The last outlier pass over a fused cloud: radius outlier removal on a
// hash grid whose cells are the radius, so each point's neighbours are in
// its own cell and the 26 around it.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <unordered_map>
#include <vector>

#include "arscout/engine/dense_reconstruction.h"

namespace arscout::engine {
namespace {

using Cell = std::array<std::int64_t, 3>;

struct CellHash {
  std::size_t operator()(const Cell& c) const {
    // Unsigned: wrapping is defined.
    const auto u = [](std::int64_t v) { return static_cast<std::uint64_t>(v); };
    return static_cast<std::size_t>(
        u(c[0]) * 73856093ULL ^ u(c[1]) * 19349663ULL ^ u(c[2]) * 83492791ULL);
  }
};

// A coordinate's cell, clamped far beyond any site (and NaN to 0) so that
// the conversion is always defined.
std::int64_t cell_index(float v, double radius) {
  constexpr double kFar = 1e15;
  const double index = std::floor(v / radius);
  if (!(index > -kFar)) return index < 0 ? static_cast<std::int64_t>(-kFar) : 0;
  return static_cast<std::int64_t>(std::min(index, kFar));
}

Cell cell_of(const ColoredPoint& p, double radius) {
  return {cell_index(p.x, radius), cell_index(p.y, radius),
          cell_index(p.z, radius)};
}

// Whether `p` has at least `wanted` points other than itself within
// `radius` among the cells around `home`.
bool has_neighbours(
    const std::vector<ColoredPoint>& points, std::size_t self, const Cell& home,
    const std::unordered_map<Cell, std::vector<std::uint32_t>, CellHash>& grid,
    double radius, int wanted) {
  const ColoredPoint& p = points[self];
  const double r2 = radius * radius;
  int found = 0;
  for (std::int64_t dx = -1; dx <= 1; ++dx)
    for (std::int64_t dy = -1; dy <= 1; ++dy)
      for (std::int64_t dz = -1; dz <= 1; ++dz) {
        const auto it = grid.find({home[0] + dx, home[1] + dy, home[2] + dz});
        if (it == grid.end()) continue;
        for (std::uint32_t j : it->second) {
          if (j == self) continue;
          const double ex = points[j].x - p.x, ey = points[j].y - p.y,
                       ez = points[j].z - p.z;
          if (ex * ex + ey * ey + ez * ez <= r2 && ++found >= wanted)
            return true;
        }
      }
  return false;
}

}  // namespace

std::vector<ColoredPoint> without_isolated_points(
    const std::vector<ColoredPoint>& points, double radius,
    int min_neighbours) {
  if (min_neighbours <= 0 || points.empty()) return points;
  if (!(radius > 0))
    throw std::invalid_argument("without_isolated_points: radius must be > 0");
  std::unordered_map<Cell, std::vector<std::uint32_t>, CellHash> grid;
  std::vector<Cell> cells;
  cells.reserve(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    cells.push_back(cell_of(points[i], radius));
    grid[cells.back()].push_back(static_cast<std::uint32_t>(i));
  }
  std::vector<ColoredPoint> kept;
  kept.reserve(points.size());
  for (std::size_t i = 0; i < points.size(); ++i)
    if (has_neighbours(points, i, cells[i], grid, radius, min_neighbours))
      kept.push_back(points[i]);
  return kept;
}

}  // namespace arscout::engine
