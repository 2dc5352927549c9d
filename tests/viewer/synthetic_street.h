// A synthetic street as a dense point cloud with exact geometry, for the
// viewer's level-of-detail and measurement tests: a 100 m x 36 m street
// (asphalt with lane marks, pavements) between blocks of houses. One house,
// the "measured house", is the box x 0..10, y 9..17, z 0..12 (ENU metres),
// so its roof's front edge, (0, 9, 12) to (10, 9, 12), is a known 10 m.
// Points are spread uniformly over the surfaces by area, with colours that
// show walls, windows and roofs.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "arscout/db/store.h"
#include "arscout/engine/ply.h"

namespace street_cloud {

inline constexpr std::array<double, 3> kEdgeStart{0, 9, 12};
inline constexpr std::array<double, 3> kEdgeEnd{10, 9, 12};

// `count` points, the same for the same count and seed.
std::vector<arscout::engine::ColoredPoint> synthetic_street(
    std::size_t count, std::uint32_t seed = 7);

// Writes /sites/{site} and its model, geo-registered at Graz, with `cloud`
// as the dense cloud the way the engine publishes one (tiles of at most a
// million points, each a PLY blob named in the model's "dense_tiles"); the
// site document names the model's version.
// With `components`, the model also holds cameras in two components (six
// frusta each, along either side of the street) and a site "{site}-before"
// whose document says it grew into this one (merged_into).
void write_street_site(arscout::db::Store& store, const std::string& site,
                       const std::vector<arscout::engine::ColoredPoint>& cloud,
                       bool components = false);

}  // namespace street_cloud
