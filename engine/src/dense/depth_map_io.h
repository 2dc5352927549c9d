// One key view's depth map as bytes (DenseReconstruction::
// serialize_depth_map and restore_depth_maps): what the sweep produced and
// nothing that changes afterwards, so the bytes of a map never change.
//
// Layout, version 3, all numbers little-endian (version 2, still read, has
// the planes as they are, 12 bytes a pixel, where version 3 has their
// deflated size and bytes; version 1, also read, has no sparse ratio):
//   magic       8 bytes  "ARSDEPTH"
//   version     u32      kDepthMapFormatVersion
//   size        u64      of the whole blob, this field and the checksum
//                        included (truncation is told apart from damage)
//   sequence    u64      the map's place in the order of sweeping
//   id          u32 length, then the bytes (UTF-8, not terminated)
//   neighbours  u32 count, then each as the id
//   rows, cols  u32, u32 (1 to 65536 each)
//   K, R        9 f64 each, row-major
//   t           3 f64
//   sparse ratio f64     SweptDepthMap::sparse_depth_ratio (>= 0, finite)
//   planes      u64 deflated size, then the bytes: zlib's deflate of the
//               depth, score and margin planes one after the other (each
//               rows * cols f32, row-major: cv::Mat CV_32F rows, exactly),
//               their bytes shuffled (util/compress.h). Lossless; with
//               the planes rounded as round_to_kept_precision does (every
//               swept map is), about 3 of their 12 bytes a pixel (the
//               zeroed low bytes, the sky's zeros and the floats'
//               repeating high bytes)
//   checksum    u32, CRC-32 (zlib's) of every byte before it
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "arscout/engine/dense.h"

namespace arscout::engine {

inline constexpr char kDepthMapMagic[8] = {'A', 'R', 'S', 'D',
                                           'E', 'P', 'T', 'H'};
inline constexpr uint32_t kDepthMapFormatVersion = 3;

// A depth map as swept: `map` with the pose its camera had then, the key
// view's neighbours in the sweep, its place in the order of sweeping, and
// how its depths compared with the model's sparse points then.
struct SweptDepthMap {
  DepthMap map;
  std::vector<std::string> neighbours;
  uint64_t sequence = 0;
  // The median, over the key view's sparse points, of the point's depth
  // over the map's depth at its pixel, at sweep time; 0 when unknown (a
  // version 1 map, or too few points). A later model whose ratio differs
  // has changed scale around this camera (sparse_depth_ratio in
  // dense_reconstruction.cpp).
  double sparse_depth_ratio = 0;
};

// Rounds `map`'s planes in place to the precision a depth map is kept at
// (round to nearest, the dropped bits zero, so that the deflated planes
// shrink): the depth to 15 bits of mantissa (2^-16 of itself: 0.15 mm at
// 10 m), the score and the margin to 7 (2^-8). The sweep's own steps are
// far coarser. DenseReconstruction rounds every map as it is swept, before
// anything reads it, so a restored map is the swept one to the bit.
// Idempotent; zeros, infinities and NaNs stay as they are.
void round_to_kept_precision(DepthMap& map);

// Throws std::invalid_argument when depth, score and margin are not CV_32F
// of one size (1 to 65536 pixels a side) or the id is empty.
std::string encode_depth_map(const SweptDepthMap& swept);

// Throws std::runtime_error naming what is wrong when `bytes` are not a
// depth map of this format: wrong magic or version, truncated or too long,
// a checksum mismatch, sizes that do not add up, planes that do not inflate
// to their size, non-finite K, R or t, a negative or non-finite sparse
// ratio. Reads versions 1 to 3.
SweptDepthMap decode_depth_map(std::string_view bytes);

// CRC-32 with zlib's polynomial (0xEDB88320, reflected, inverted).
uint32_t depth_map_crc32(std::string_view bytes);

}  // namespace arscout::engine
