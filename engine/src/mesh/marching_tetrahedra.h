// Polygonising a sampled implicit function on a regular grid: each cube is
// split into the six tetrahedra of its Kuhn (Freudenthal) triangulation,
// which agree across shared faces, and each tetrahedron whose corners
// change sign yields one triangle or two. A vertex is keyed by the two grid
// corners of its edge, so cubes (and tiles) that share an edge share its
// vertex, at the same position when they read the same corner values.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace arscout::engine::mesh {

using GridIndex = std::array<std::int64_t, 3>;

// Packs a grid index (each axis within +-2^20) into one key.
std::uint64_t grid_key(const GridIndex& i);

struct IsoSurface {
  std::vector<Eigen::Vector3d> positions;
  std::vector<std::uint32_t> indices;  // three per triangle
};

// The zero set of `value` over the cubes whose lowest corner is listed in
// `cubes` (each once), on the grid of step `cell` anchored at the origin.
// `value` gives a corner's value (negative inside, positive on the side the
// surface faces) or nothing when unknown: a cube with an unknown corner, or
// with a corner value beyond `max_abs_value`, makes no triangles (the
// function is not a distance there). Triangles wind counter-clockwise seen
// from the positive side.
IsoSurface polygonise(
    const std::vector<GridIndex>& cubes, double cell,
    const std::function<std::optional<float>(const GridIndex&)>& value,
    double max_abs_value);

}  // namespace arscout::engine::mesh
