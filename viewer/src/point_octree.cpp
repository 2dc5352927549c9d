#include "point_octree.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <unordered_set>
#include <utility>

namespace arscout::viewer {

std::array<double, 3> OctreeBox::centre() const {
  return {(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, (lo[2] + hi[2]) / 2};
}

double OctreeBox::diagonal() const {
  return std::hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
}

OctreeBox OctreeBox::octant(int octant) const {
  const auto c = centre();
  OctreeBox b;
  for (int a = 0; a < 3; ++a) {
    const bool upper = (octant >> a) & 1;
    b.lo[a] = upper ? c[a] : lo[a];
    b.hi[a] = upper ? hi[a] : c[a];
  }
  return b;
}

namespace {

int octant_of(const OctreeBox& box, const engine::ColoredPoint& p) {
  const auto c = box.centre();
  return (p.x >= c[0] ? 1 : 0) | (p.y >= c[1] ? 2 : 0) | (p.z >= c[2] ? 4 : 0);
}

class OctreeBuilder {
 public:
  OctreeBuilder(const std::vector<engine::ColoredPoint>& points,
                const OctreeOptions& options)
      : points_(points),
        options_(options),
        grid_(std::max(
            1, static_cast<int>(std::ceil(
                   std::cbrt(static_cast<double>(options.max_node_points)))))) {
  }

  // Adds the node for `indices` in `box`, then its children; returns its
  // index in the list.
  std::size_t add(std::vector<std::uint32_t> indices, const OctreeBox& box,
                  int depth, std::string name) {
    const std::size_t at = nodes_.size();
    nodes_.push_back({std::move(name), depth, box, 0, {}, {}});
    std::vector<std::uint32_t> rest;
    if (indices.size() > options_.max_node_points &&
        depth < options_.max_depth) {
      rest = split_sample(&indices, box);
      nodes_[at].spacing = box.diagonal() / grid_;
    }
    nodes_[at].points = std::move(indices);
    std::array<std::vector<std::uint32_t>, 8> octants;
    for (std::uint32_t i : rest)
      octants[octant_of(box, points_[i])].push_back(i);
    rest = {};
    for (int o = 0; o < 8; ++o) {
      if (octants[o].empty()) continue;
      const std::size_t child =
          add(std::move(octants[o]), box.octant(o), depth + 1,
              nodes_[at].name + static_cast<char>('0' + o));
      nodes_[at].children.push_back(child);
    }
    return at;
  }

  std::vector<OctreeNode> take() { return std::move(nodes_); }

 private:
  // Keeps in *indices one point per cell of a grid_^3 grid over `box` (a
  // sample spread over the box), and returns the others.
  std::vector<std::uint32_t> split_sample(std::vector<std::uint32_t>* indices,
                                          const OctreeBox& box) const {
    std::unordered_set<std::int64_t> taken;
    taken.reserve(std::min<std::size_t>(
        indices->size(), static_cast<std::size_t>(grid_) * grid_ * grid_));
    std::vector<std::uint32_t> kept, rest;
    for (std::uint32_t i : *indices) {
      const engine::ColoredPoint& p = points_[i];
      const double xyz[3] = {p.x, p.y, p.z};
      std::int64_t cell = 0;
      for (int a = 0; a < 3; ++a) {
        const double size = std::max(box.hi[a] - box.lo[a], 1e-9);
        const auto k = static_cast<std::int64_t>(
            std::clamp(std::floor((xyz[a] - box.lo[a]) / size * grid_), 0.0,
                       static_cast<double>(grid_ - 1)));
        cell = cell * grid_ + k;
      }
      (taken.insert(cell).second ? kept : rest).push_back(i);
    }
    *indices = std::move(kept);
    return rest;
  }

  const std::vector<engine::ColoredPoint>& points_;
  const OctreeOptions& options_;
  const int grid_;
  std::vector<OctreeNode> nodes_;
};

OctreeBox bounds_of(const std::vector<engine::ColoredPoint>& points) {
  OctreeBox box;
  box.lo = {points[0].x, points[0].y, points[0].z};
  box.hi = box.lo;
  for (const engine::ColoredPoint& p : points) {
    const double xyz[3] = {p.x, p.y, p.z};
    for (int a = 0; a < 3; ++a) {
      box.lo[a] = std::min(box.lo[a], xyz[a]);
      box.hi[a] = std::max(box.hi[a], xyz[a]);
    }
  }
  return box;
}

}  // namespace

std::vector<OctreeNode> build_point_octree(
    const std::vector<engine::ColoredPoint>& points,
    const OctreeOptions& options) {
  if (points.empty())
    throw std::invalid_argument("octree: the cloud has no points");
  std::vector<std::uint32_t> all(points.size());
  for (std::uint32_t i = 0; i < all.size(); ++i) all[i] = i;
  OctreeBuilder builder(points, options);
  builder.add(std::move(all), bounds_of(points), 0, "r");
  return builder.take();
}

}  // namespace arscout::viewer
