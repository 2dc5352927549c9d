// Coloured point clouds as PLY (Stanford polygon files), the format
// MeshLab, CloudCompare and COLMAP exchange point clouds in.
//
// Writing produces one of two layouts (binary little-endian, float x y z and
// uchar red green blue, then for fused dense points float nx ny nz, uchar
// support and uchar score), whatever the host's byte order. Reading accepts the
// vertex element of most PLY files written by other tools; it is meant for
// untrusted bytes: every malformed input ends in std::runtime_error, never in
// a read outside the buffer.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace arscout::engine {

struct ColoredPoint {
  float x = 0, y = 0, z = 0;
  uint8_t r = 0, g = 0, b = 0;
  // A fused dense point's unit normal (toward the cameras that saw it; zero
  // when unknown) and its support: how many depth maps measured it (its
  // own and those that agree with it, at most 255). 0: not a fused point
  // (sparse points, files from other tools).
  float nx = 0, ny = 0, nz = 0;
  uint8_t support = 0;
  // A fused dense point's photometric score: the mean winning ZNCC of the
  // depths fused into it, times 255 and rounded (0 when unknown, and for
  // points that are not fused).
  uint8_t score = 0;
};

// Points measured by at least this many depth maps (their own and two
// neighbours that agree: the issue's "consistent with at least two
// neighbour views") are confident; the viewer shows only those by default.
constexpr uint8_t kConfidentSupport = 3;

// Whether `p` is shown when fused points need `min_support` depth maps: a
// point that is not fused (support 0: sparse, other tools') always is.
inline bool shown_at(const ColoredPoint& p, int min_support) {
  return p.support == 0 || p.support >= min_support;
}

// The whole file: the header
//
//   ply
//   format binary_little_endian 1.0
//   comment <comment>
//   element vertex <N>
//   property float x
//   property float y
//   property float z
//   property uchar red
//   property uchar green
//   property uchar blue
//   end_header
//
// (each line ended by '\n'), then 15 bytes per point in that order. When any
// point has a support, five more properties follow blue,
//
//   property float nx
//   property float ny
//   property float nz
//   property uchar support
//   property uchar score
//
// and each point takes 29 bytes. The
// comment is "written by arscout" unless given; throws std::invalid_argument
// when it holds a line break (it would end the header line early).
std::string encode_ply(const std::vector<ColoredPoint>& points,
                       std::string_view comment = "written by arscout");

// encode_ply's bytes at `path`, atomically: a temporary file next to it is
// written, flushed to disk and renamed over `path`, so readers see either
// the old file or the whole new one. Throws std::runtime_error naming
// `path` on failure (and leaves no temporary file behind).
void write_ply(const std::string& path, const std::vector<ColoredPoint>& points,
               std::string_view comment = "written by arscout");

// The vertices of a PLY file, in file order.
//
// Accepted: formats ascii 1.0 and binary_little_endian 1.0; exactly one
// "vertex" element, with scalar properties x, y and z of any numeric type
// (float/float32 or double/float64 as a rule; values beyond float's range
// become infinities) and optionally red, green and blue of type uchar/uint8
// (0 when absent), nx, ny and nz of any numeric type and support and score
// of an integer type (values beyond 0..255 clamped), 0 when absent. Other
// scalar vertex properties (alpha, ...) are skipped. Other elements are skipped
// when they come before the vertices and ignored when they come after; "\r\n"
// line ends are tolerated.
//
// Throws std::runtime_error saying what is wrong for: no "ply" magic, no
// end_header, a format other than the two above (binary_big_endian is
// reported as unsupported), a missing, malformed or impossible vertex count
// (more vertices than the remaining bytes could hold), a list property in
// the vertex element, a missing x/y/z, colours of another type, a body that
// ends before the last vertex, and ascii values that are not numbers.
std::vector<ColoredPoint> decode_ply(std::string_view bytes);

// decode_ply on the file's bytes; errors name `path`.
std::vector<ColoredPoint> read_ply(const std::string& path);

}  // namespace arscout::engine
