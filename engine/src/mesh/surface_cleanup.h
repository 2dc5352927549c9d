// Cleaning a polygonised surface: small disconnected pieces (floaters)
// go, unless they reach the column's border, where they may continue in
// the neighbouring tile.
#pragma once

#include <functional>

#include <Eigen/Core>

#include "arscout/engine/mesh.h"

namespace arscout::engine::mesh {

// Removes the connected pieces (triangles joined by shared vertices) of
// less than `min_area` and with no vertex for which `on_column_border`
// holds, then the vertices no triangle uses (their
// per-vertex attributes with them).
void drop_small_pieces(
    TexturedMesh& mesh, double min_area,
    const std::function<bool(const Eigen::Vector3f&)>& on_column_border);

}  // namespace arscout::engine::mesh
