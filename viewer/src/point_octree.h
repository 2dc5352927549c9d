// An octree of a point cloud for level of detail, shared by the 3D Tiles
// export (point_tileset.h) and the web viewer's streamed cloud
// (cloud_octree.h): each node keeps a spread-out sample of the points in
// its box, at most one per cell of a grid over the box, and its children
// hold the rest (additive refinement, as Potree and 3D Tiles' ADD do). A
// node is split while it has more than max_node_points points; drawing a
// node and all its ancestors shows its box at the node's sample spacing.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "arscout/engine/ply.h"

namespace arscout::viewer {

struct OctreeBox {
  std::array<double, 3> lo{}, hi{};
  std::array<double, 3> centre() const;
  double diagonal() const;
  OctreeBox octant(int octant) const;  // bit a set: the upper half on axis a
};

struct OctreeOptions {
  std::size_t max_node_points = 50000;  // a node with more is split
  int max_depth = 16;                   // below that, a leaf keeps the rest
};

struct OctreeNode {
  // Its path from the root: "r", then one octant digit (0-7) per level.
  std::string name;
  int depth = 0;
  OctreeBox box;
  // The distance between the node's sample points on its grid (the box's
  // diagonal over the cells per axis); 0 for a leaf, which holds all that
  // is left of its box.
  double spacing = 0;
  std::vector<std::uint32_t> points;  // indices into the cloud
  std::vector<std::size_t> children;  // indices into the node list
};

// The nodes, the root first and every node before its children. Throws
// std::invalid_argument for an empty cloud.
std::vector<OctreeNode> build_point_octree(
    const std::vector<engine::ColoredPoint>& points,
    const OctreeOptions& options = {});

}  // namespace arscout::viewer
