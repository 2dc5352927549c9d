// A binary glTF 2.0 (.glb) holding one point primitive: float positions
// and 8-bit colours, the content of a 3D Tiles point tile. glTF is y-up:
// callers give positions already in glTF axes.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace arscout::viewer {

struct GlbPoints {
  std::array<double, 3> translation{};  // the node's, in glTF axes
  // Relative to `translation`, so floats keep millimetres near the tile.
  std::vector<std::array<float, 3>> positions;
  std::vector<std::array<std::uint8_t, 3>> colours;  // one per position
};

// Throws std::invalid_argument when there are no points or the colours do
// not match the positions one to one.
std::string encode_glb_points(const GlbPoints& points);

}  // namespace arscout::viewer
