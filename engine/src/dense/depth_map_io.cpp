#include "dense/depth_map_io.h"

#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <initializer_list>
#include <stdexcept>
#include <string>
#include <string_view>

#include "arscout/util/bytes.h"
#include "arscout/util/compress.h"

namespace arscout::engine {
namespace {

constexpr uint32_t kMaxSide = 65536;
constexpr size_t kHeaderBytes = 8 + 4 + 8;  // magic, version, size
constexpr size_t kChecksumBytes = 4;
constexpr bool kLittleEndian = std::endian::native == std::endian::little;
// Begins the message of every std::runtime_error decode_depth_map throws.
constexpr char kNotADepthMap[] = "not a depth map of this format: ";

[[noreturn]] void fail(const std::string& what) {
  throw std::runtime_error(kNotADepthMap + what);
}

// The format's pieces over util::ByteWriter: strings as a u32 length then
// the bytes, Eigen matrices row-major as f64, planes as CV_32F rows.
class Writer {
 public:
  template <typename T>
  void put(T value) {
    static_assert(sizeof(T) == 4 || sizeof(T) == 8);
    out_.put(value);
  }
  void text(const std::string& s) {
    put(static_cast<uint32_t>(s.size()));
    out_.append(s);
  }
  template <typename Derived>
  void row_major(const Eigen::MatrixBase<Derived>& m) {
    for (Eigen::Index r = 0; r < m.rows(); ++r)
      for (Eigen::Index c = 0; c < m.cols(); ++c)
        put(static_cast<double>(m(r, c)));
  }
  // A little-endian host writes each row at once: the planes are most of
  // the bytes.
  void plane(const cv::Mat& mat) {
    for (int y = 0; y < mat.rows; ++y) {
      const float* row = mat.ptr<float>(y);
      if constexpr (kLittleEndian) {
        out_.append(row, sizeof(float) * mat.cols);
      } else {
        for (int x = 0; x < mat.cols; ++x) put(row[x]);
      }
    }
  }
  // Version 3: the planes' floats one after another, their bytes shuffled
  // (util/compress.h) and deflated, as the deflated size and the bytes.
  void deflated_planes(std::initializer_list<const cv::Mat*> planes) {
    Writer raw;
    for (const cv::Mat* p : planes) raw.plane(*p);
    const std::string deflated = util::deflate_bytes(
        util::shuffle_bytes(raw.bytes().bytes(), sizeof(float)));
    put(static_cast<uint64_t>(deflated.size()));
    out_.append(deflated);
  }
  util::ByteWriter& bytes() { return out_; }

 private:
  util::ByteWriter out_;
};

// The inverse of Writer over util::ByteReader. Each read names its field,
// so that running out of bytes says which one ("sizes inconsistent: id runs
// past the end of the map"): checked here before util's own "truncated".
class Reader {
 public:
  explicit Reader(std::string_view in) : in_(in, kNotADepthMap) {}

  template <typename T>
  T get(const char* what) {
    static_assert(sizeof(T) == 4 || sizeof(T) == 8);
    need(sizeof(T), what);
    return in_.get<T>();
  }
  std::string text(const char* what) {
    const uint32_t n = get<uint32_t>(what);
    need(n, what);
    return std::string(in_.take(n));
  }
  template <typename Matrix>
  Matrix row_major(const char* what) {
    Matrix m;
    for (Eigen::Index r = 0; r < m.rows(); ++r)
      for (Eigen::Index c = 0; c < m.cols(); ++c) m(r, c) = get<double>(what);
    if (!m.allFinite()) fail(std::string("non-finite ") + what);
    return m;
  }
  cv::Mat plane(int rows, int cols, const char* what) {
    need(sizeof(float) * static_cast<size_t>(rows) * cols, what);
    cv::Mat mat(rows, cols, CV_32F);
    for (int y = 0; y < rows; ++y) {
      float* row = mat.ptr<float>(y);
      if constexpr (kLittleEndian) {
        const std::string_view raw = in_.take(sizeof(float) * cols);
        std::memcpy(row, raw.data(), raw.size());
      } else {
        for (int x = 0; x < cols; ++x) row[x] = in_.get<float>();
      }
    }
    return mat;
  }
  // The inverse of Writer::deflated_planes: `size` bytes of planes, in
  // the order written, unshuffled.
  std::string inflated_planes(uint64_t size) {
    const uint64_t deflated = get<uint64_t>("deflated size");
    if (deflated != left())
      fail("sizes inconsistent: " + std::to_string(deflated) +
           " deflated bytes of planes stated, " + std::to_string(left()) +
           " are there");
    try {
      return util::unshuffle_bytes(
          util::inflate_bytes(in_.take(deflated), size), sizeof(float));
    } catch (const std::runtime_error& e) {
      fail("sizes inconsistent: the planes do not inflate to the " +
           std::to_string(size) + " bytes their pixels need (" + e.what() +
           ")");
    }
  }
  size_t left() const { return in_.left(); }

 private:
  void need(size_t n, const char* what) const {
    if (left() < n)
      fail(std::string("sizes inconsistent: ") + what +
           " runs past the end of the map");
  }

  util::ByteReader in_;
};

constexpr std::array<uint32_t, 256> crc_table() {
  std::array<uint32_t, 256> table{};
  for (uint32_t i = 0; i < 256; ++i) {
    uint32_t c = i;
    for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
    table[i] = c;
  }
  return table;
}

std::string planes_missing(uint32_t rows, uint32_t cols, size_t there) {
  return "sizes inconsistent: " + std::to_string(cols) + " x " +
         std::to_string(rows) + " pixels need " +
         std::to_string(3 * sizeof(float) * uint64_t{rows} * cols) +
         " bytes of depth, score and margin, " + std::to_string(there) +
         " are there";
}

void read_planes(Reader& r, uint32_t rows, uint32_t cols, DepthMap& map) {
  map.depth = r.plane(rows, cols, "depth");
  map.score = r.plane(rows, cols, "score");
  map.margin = r.plane(rows, cols, "margin");
}

void check_plane(const cv::Mat& mat, cv::Size size, const char* what) {
  if (mat.type() != CV_32F || mat.size() != size)
    throw std::invalid_argument(std::string("depth map ") + what +
                                " is not CV_32F of the depth's size");
}

// `value` to `kept` bits of mantissa, to nearest (a carry into the
// exponent is the next binade, as it should be).
float round_mantissa(float value, int kept) {
  if (!std::isfinite(value) || value == 0) return value;
  const int dropped = 23 - kept;
  const uint32_t bits = std::bit_cast<uint32_t>(value);
  const uint32_t rounded =
      (bits + (uint32_t{1} << (dropped - 1))) & ~((uint32_t{1} << dropped) - 1);
  return std::bit_cast<float>(rounded);
}

void round_plane(cv::Mat& plane, int kept) {
  for (int y = 0; y < plane.rows; ++y) {
    float* row = plane.ptr<float>(y);
    for (int x = 0; x < plane.cols; ++x) row[x] = round_mantissa(row[x], kept);
  }
}

}  // namespace

void round_to_kept_precision(DepthMap& map) {
  round_plane(map.depth, 15);
  round_plane(map.score, 7);
  round_plane(map.margin, 7);
}

uint32_t depth_map_crc32(std::string_view bytes) {
  static constexpr std::array<uint32_t, 256> kTable = crc_table();
  uint32_t c = 0xFFFFFFFFu;
  for (char byte : bytes)
    c = kTable[(c ^ static_cast<unsigned char>(byte)) & 0xff] ^ (c >> 8);
  return c ^ 0xFFFFFFFFu;
}

std::string encode_depth_map(const SweptDepthMap& swept) {
  const DepthMap& map = swept.map;
  if (map.id.empty()) throw std::invalid_argument("depth map without an id");
  if (map.depth.empty() || map.depth.rows > static_cast<int>(kMaxSide) ||
      map.depth.cols > static_cast<int>(kMaxSide))
    throw std::invalid_argument("depth map of '" + map.id +
                                "' is empty or too large");
  check_plane(map.depth, map.depth.size(), "depth");
  check_plane(map.score, map.depth.size(), "score");
  check_plane(map.margin, map.depth.size(), "margin");

  Writer w;
  w.bytes().reserve(256 + 2 * sizeof(float) * map.depth.total());
  w.bytes().append(kDepthMapMagic, sizeof(kDepthMapMagic));
  w.put(kDepthMapFormatVersion);
  w.put(uint64_t{0});  // the size, filled in below
  w.put(swept.sequence);
  w.text(map.id);
  w.put(static_cast<uint32_t>(swept.neighbours.size()));
  for (const std::string& n : swept.neighbours) w.text(n);
  w.put(static_cast<uint32_t>(map.depth.rows));
  w.put(static_cast<uint32_t>(map.depth.cols));
  w.row_major(map.K);
  w.row_major(map.R);
  w.row_major(map.t);
  w.put(swept.sparse_depth_ratio);
  w.deflated_planes({&map.depth, &map.score, &map.margin});

  util::ByteWriter& out = w.bytes();
  out.put_at<uint64_t>(sizeof(kDepthMapMagic) + 4, out.size() + kChecksumBytes);
  out.put(depth_map_crc32(out.bytes()));
  return out.take();
}

SweptDepthMap decode_depth_map(std::string_view bytes) {
  if (bytes.size() < sizeof(kDepthMapMagic) ||
      std::memcmp(bytes.data(), kDepthMapMagic, sizeof(kDepthMapMagic)) != 0)
    fail(bytes.size() < sizeof(kDepthMapMagic)
             ? "truncated: " + std::to_string(bytes.size()) +
                   " bytes, shorter than the magic"
             : std::string("wrong magic (expected \"ARSDEPTH\")"));
  Reader r(bytes.substr(sizeof(kDepthMapMagic)));
  if (bytes.size() < sizeof(kDepthMapMagic) + 4)
    fail("truncated: " + std::to_string(bytes.size()) +
         " bytes, shorter than the header");
  const uint32_t version = r.get<uint32_t>("version");
  if (version < 1 || version > kDepthMapFormatVersion)
    fail("format version " + std::to_string(version) +
         ", this build reads versions 1 to " +
         std::to_string(kDepthMapFormatVersion));
  if (bytes.size() < kHeaderBytes)
    fail("truncated: " + std::to_string(bytes.size()) +
         " bytes, shorter than the header");
  const uint64_t size = r.get<uint64_t>("size");
  if (bytes.size() < size)
    fail("truncated: " + std::to_string(bytes.size()) + " of " +
         std::to_string(size) + " bytes");
  if (bytes.size() > size)
    fail(std::to_string(bytes.size() - size) +
         " bytes after the end of the map");
  if (size < kHeaderBytes + kChecksumBytes)
    fail("sizes inconsistent: a size of " + std::to_string(size) + " bytes");
  const std::string_view body = bytes.substr(0, size - kChecksumBytes);
  Reader tail(bytes.substr(body.size()));
  if (tail.get<uint32_t>("checksum") != depth_map_crc32(body))
    fail("checksum mismatch (the bytes are damaged)");

  Reader b(body.substr(kHeaderBytes));
  SweptDepthMap swept;
  DepthMap& map = swept.map;
  swept.sequence = b.get<uint64_t>("sequence");
  map.id = b.text("id");
  if (map.id.empty()) fail("an empty id");
  const uint32_t neighbours = b.get<uint32_t>("neighbour count");
  // Each neighbour takes at least its length: bounds the reservation.
  if (neighbours > b.left() / 4)
    fail("sizes inconsistent: " + std::to_string(neighbours) + " neighbours");
  swept.neighbours.reserve(neighbours);
  for (uint32_t i = 0; i < neighbours; ++i)
    swept.neighbours.push_back(b.text("a neighbour's id"));
  const uint32_t rows = b.get<uint32_t>("rows");
  const uint32_t cols = b.get<uint32_t>("cols");
  if (rows < 1 || cols < 1 || rows > kMaxSide || cols > kMaxSide)
    fail("sizes inconsistent: " + std::to_string(cols) + " x " +
         std::to_string(rows) + " pixels");
  map.K = b.row_major<Eigen::Matrix3d>("K");
  map.R = b.row_major<Eigen::Matrix3d>("R");
  map.t = b.row_major<Eigen::Vector3d>("t");
  if (version >= 2) {
    swept.sparse_depth_ratio = b.get<double>("sparse ratio");
    if (!std::isfinite(swept.sparse_depth_ratio) ||
        swept.sparse_depth_ratio < 0)
      fail("a sparse ratio of " + std::to_string(swept.sparse_depth_ratio));
  }
  const uint64_t planes = 3 * sizeof(float) * uint64_t{rows} * cols;
  if (version >= 3) {
    const std::string raw = b.inflated_planes(planes);
    Reader p(raw);
    read_planes(p, rows, cols, map);
  } else {
    if (b.left() != planes) fail(planes_missing(rows, cols, b.left()));
    read_planes(b, rows, cols, map);
  }
  return swept;
}

}  // namespace arscout::engine
