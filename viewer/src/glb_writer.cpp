#include "glb_writer.h"

#include <algorithm>
#include <limits>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "arscout/util/bytes.h"

namespace arscout::viewer {
namespace {

using Json = nlohmann::json;

constexpr std::uint32_t kGlbMagic = 0x46546c67;  // "glTF"
constexpr std::uint32_t kJsonChunk = 0x4e4f534a;
constexpr std::uint32_t kBinChunk = 0x004e4942;
constexpr int kFloat = 5126, kUnsignedByte = 5121, kArrayBuffer = 34962;
constexpr int kPointsMode = 0;

// The binary chunk: positions, then RGBA colours (4 bytes a point, as
// vertex attributes must be 4-byte aligned).
std::string binary_of(const GlbPoints& points) {
  util::ByteWriter bin;
  for (const auto& p : points.positions)
    for (float v : p) bin.put<float>(v);
  for (const auto& c : points.colours) {
    for (std::uint8_t v : c) bin.put<std::uint8_t>(v);
    bin.put<std::uint8_t>(255);
  }
  return bin.take();
}

Json gltf_of(const GlbPoints& points, std::size_t binary_size) {
  std::array<float, 3> lo, hi;
  lo.fill(std::numeric_limits<float>::max());
  hi.fill(std::numeric_limits<float>::lowest());
  for (const auto& p : points.positions)
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], p[a]);
      hi[a] = std::max(hi[a], p[a]);
    }
  const std::size_t n = points.positions.size();
  return Json{{"asset", {{"version", "2.0"}, {"generator", "arscout"}}},
              {"scene", 0},
              {"scenes", {{{"nodes", {0}}}}},
              {"nodes", {{{"mesh", 0}, {"translation", points.translation}}}},
              {"meshes",
               {{{"primitives",
                  {{{"attributes", {{"POSITION", 0}, {"COLOR_0", 1}}},
                    {"mode", kPointsMode}}}}}}},
              {"buffers", {{{"byteLength", binary_size}}}},
              {"bufferViews",
               {{{"buffer", 0},
                 {"byteOffset", 0},
                 {"byteLength", 12 * n},
                 {"target", kArrayBuffer}},
                {{"buffer", 0},
                 {"byteOffset", 12 * n},
                 {"byteLength", 4 * n},
                 {"target", kArrayBuffer}}}},
              {"accessors",
               {{{"bufferView", 0},
                 {"componentType", kFloat},
                 {"count", n},
                 {"type", "VEC3"},
                 {"min", lo},
                 {"max", hi}},
                {{"bufferView", 1},
                 {"componentType", kUnsignedByte},
                 {"normalized", true},
                 {"count", n},
                 {"type", "VEC4"}}}}};
}

std::string padded(std::string chunk, char fill) {
  chunk.resize((chunk.size() + 3) / 4 * 4, fill);
  return chunk;
}

}  // namespace

std::string encode_glb_points(const GlbPoints& points) {
  if (points.positions.empty() ||
      points.colours.size() != points.positions.size())
    throw std::invalid_argument(
        "glb: points need positions and one colour each");
  const std::string bin = padded(binary_of(points), '\0');
  const std::string json = padded(gltf_of(points, bin.size()).dump(), ' ');
  util::ByteWriter glb;
  glb.put<std::uint32_t>(kGlbMagic);
  glb.put<std::uint32_t>(2);
  glb.put<std::uint32_t>(
      static_cast<std::uint32_t>(12 + 8 + json.size() + 8 + bin.size()));
  glb.put<std::uint32_t>(static_cast<std::uint32_t>(json.size()));
  glb.put<std::uint32_t>(kJsonChunk);
  glb.append(json);
  glb.put<std::uint32_t>(static_cast<std::uint32_t>(bin.size()));
  glb.put<std::uint32_t>(kBinChunk);
  glb.append(bin);
  return glb.take();
}

}  // namespace arscout::viewer
