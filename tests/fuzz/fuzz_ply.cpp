// PLY point clouds (decode_ply, engine/include/arscout/engine/ply.h), which
// the header says are read as untrusted bytes: every malformed input ends
// in std::runtime_error, never in a read outside the buffer. The points of
// a file that reads must survive encode_ply and decode_ply unchanged, bit
// for bit (NaNs included).
#include <bit>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "arscout/engine/ply.h"
#include "fuzz_support.h"

namespace {

namespace engine = arscout::engine;
using arscout::fuzz::check;

bool same_bits(float a, float b) {
  return std::bit_cast<std::uint32_t>(a) == std::bit_cast<std::uint32_t>(b);
}

bool same_point(const engine::ColoredPoint& a, const engine::ColoredPoint& b) {
  return same_bits(a.x, b.x) && same_bits(a.y, b.y) && same_bits(a.z, b.z) &&
         a.r == b.r && a.g == b.g && a.b == b.b;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data,
                                      std::size_t size) {
  std::vector<engine::ColoredPoint> points;
  try {
    points = engine::decode_ply(arscout::fuzz::as_text(data, size));
  } catch (const std::runtime_error&) {
    return 0;  // the documented refusal
  }
  const std::string encoded = engine::encode_ply(points);
  std::vector<engine::ColoredPoint> again;
  try {
    again = engine::decode_ply(encoded);
  } catch (const std::runtime_error&) {
    arscout::fuzz::fail("decode_ply reads what encode_ply wrote");
  }
  check(again.size() == points.size(), "a round trip keeps every point");
  for (std::size_t i = 0; i < points.size(); ++i)
    check(same_point(again[i], points[i]), "a round trip keeps each point");
  return 0;
}
