#include "state_parts.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cstdint>
#include <cstdio>

#include "arscout/db/store.h"

namespace arscout::engine::service {
namespace {

constexpr size_t kSmallestPart = 64 << 10;
constexpr const char* kPartPrefix = "state-";

// One pseudo-random word per byte value for the rolling ("gear") hash:
// shifting left by one per byte lets a byte's influence leave the hash
// after 64 bytes, so the hash at a position depends on those bytes only.
std::array<std::uint64_t, 256> gear_table() {
  std::array<std::uint64_t, 256> table{};
  std::uint64_t state = 0x5eed5eed5eed5eedULL;
  for (std::uint64_t& word : table) {  // splitmix64
    state += 0x9e3779b97f4a7c15ULL;
    std::uint64_t z = state;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    word = z ^ (z >> 31);
  }
  return table;
}

// The minimum part size for a state of `size` bytes: a power of two, so
// that it changes only when the state doubles.
size_t smallest_part(size_t size) {
  return std::max(kSmallestPart, std::bit_ceil(size / kMaxStateParts + 1));
}

}  // namespace

std::vector<std::string_view> cut_state_parts(std::string_view bytes) {
  static const std::array<std::uint64_t, 256> gear = gear_table();
  const size_t min_part = smallest_part(bytes.size());
  const size_t max_part = 8 * min_part;
  // A cut where the hash's top bits are zero: one chance in 2 * min_part
  // per byte past the minimum, so parts average about 3 x min_part.
  const std::uint64_t mask = ~std::uint64_t{0}
                             << (64 - std::bit_width(2 * min_part - 1));
  std::vector<std::string_view> parts;
  size_t begin = 0;
  while (begin < bytes.size()) {
    const size_t limit = std::min(bytes.size(), begin + max_part);
    size_t end = std::min(limit, begin + min_part);
    std::uint64_t hash = 0;  // of the 64 bytes before `end`
    for (size_t i = end - std::min(end - begin, size_t{64}); i < end; ++i)
      hash = (hash << 1) + gear[static_cast<unsigned char>(bytes[i])];
    while (end < limit && (hash & mask) != 0)
      hash = (hash << 1) + gear[static_cast<unsigned char>(bytes[end++])];
    parts.push_back(bytes.substr(begin, end - begin));
    begin = end;
  }
  return parts;
}

std::string state_part_name(size_t index) {
  char name[32];
  std::snprintf(name, sizeof name, "%s%04zu", kPartPrefix, index);
  return name;
}

std::optional<std::string> read_state_bytes(db::Store& store,
                                            const db::Document& engine_doc) {
  if (auto whole = engine_doc.blobs.find("state");
      whole != engine_doc.blobs.end())
    return store.get_blob(whole->second);
  if (!engine_doc.blobs.count(state_part_name(0))) return std::nullopt;
  std::string bytes;
  for (size_t i = 0;; ++i) {
    auto part = engine_doc.blobs.find(state_part_name(i));
    if (part == engine_doc.blobs.end()) return bytes;
    bytes += store.get_blob(part->second);
  }
}

}  // namespace arscout::engine::service
