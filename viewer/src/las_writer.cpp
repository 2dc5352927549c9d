#include "las_writer.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "arscout/util/bytes.h"

namespace arscout::viewer {
namespace {

constexpr std::uint16_t kHeaderSize = 375;
constexpr std::uint16_t kVlrHeaderSize = 54;
constexpr std::uint8_t kPointFormat = 7;
constexpr std::uint16_t kPointSize = 36;
constexpr std::uint16_t kExtraBytes = 14;  // support, 3 floats, score
constexpr std::uint16_t kExtraBytesFields = 5;
constexpr std::uint16_t kExtraBytesRecordId = 4;
constexpr std::uint16_t kExtraBytesDescriptorSize = 192;
constexpr std::uint16_t kGlobalEncodingWkt = 1 << 4;
constexpr std::uint16_t kWktRecordId = 2112;  // OGC coordinate system WKT

struct Axis {
  double scale = 0.001, offset = 0, min = 0, max = 0;
};

void put_text(util::ByteWriter& out, const std::string& text, size_t size) {
  std::string field = text.substr(0, size);
  field.resize(size, '\0');
  out.append(field);
}

std::array<Axis, 3> axes_of(const std::vector<LasPoint>& points,
                            const LasFile& file) {
  std::array<Axis, 3> axes;
  for (int a = 0; a < 3; ++a) {
    axes[a].scale = a < 2 ? file.xy_scale : file.z_scale;
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (const LasPoint& p : points) {
      if (!std::isfinite(p.xyz[a]))
        throw std::invalid_argument("las: a coordinate is not finite");
      lo = std::min(lo, p.xyz[a]);
      hi = std::max(hi, p.xyz[a]);
    }
    if (points.empty()) lo = hi = 0;
    axes[a].offset = std::floor(lo);
    if ((hi - axes[a].offset) / axes[a].scale >
        std::numeric_limits<std::int32_t>::max() - 1)
      throw std::invalid_argument(
          "las: the cloud spans more than 32-bit integers hold at scale " +
          std::to_string(axes[a].scale));
  }
  return axes;
}

std::int32_t quantize(double v, const Axis& axis) {
  return static_cast<std::int32_t>(
      std::llround((v - axis.offset) / axis.scale));
}

// The bounds as the stored integers give them back.
void measure_bounds(const std::vector<LasPoint>& points,
                    std::array<Axis, 3>* axes) {
  for (Axis& axis : *axes) axis.min = axis.max = axis.offset;
  for (int a = 0; a < 3; ++a) {
    Axis& axis = (*axes)[a];
    std::int32_t lo = std::numeric_limits<std::int32_t>::max(), hi = -lo;
    for (const LasPoint& p : points) {
      lo = std::min(lo, quantize(p.xyz[a], axis));
      hi = std::max(hi, quantize(p.xyz[a], axis));
    }
    if (points.empty()) continue;
    axis.min = axis.offset + lo * axis.scale;
    axis.max = axis.offset + hi * axis.scale;
  }
}

void put_header(util::ByteWriter& out, const LasFile& file,
                const std::array<Axis, 3>& axes, std::uint64_t count,
                std::uint32_t point_offset, bool extra) {
  out.append("LASF");
  out.put<std::uint16_t>(0);  // file source id
  out.put<std::uint16_t>(kGlobalEncodingWkt);
  out.append(std::string(16, '\0'));  // project GUID
  out.put<std::uint8_t>(1);
  out.put<std::uint8_t>(4);
  put_text(out, "arscout", 32);  // system identifier
  put_text(out, file.software, 32);
  out.put<std::uint16_t>(static_cast<std::uint16_t>(file.day_of_year));
  out.put<std::uint16_t>(static_cast<std::uint16_t>(file.year));
  out.put<std::uint16_t>(kHeaderSize);
  out.put<std::uint32_t>(point_offset);
  out.put<std::uint32_t>(extra ? 2 : 1);  // the WKT, the extra bytes
  out.put<std::uint8_t>(kPointFormat);
  out.put<std::uint16_t>(extra ? kPointSize + kExtraBytes : kPointSize);
  out.put<std::uint32_t>(0);  // legacy point count: 0 for formats 6-10
  for (int r = 0; r < 5; ++r) out.put<std::uint32_t>(0);
  for (const Axis& a : axes) out.put<double>(a.scale);
  for (const Axis& a : axes) out.put<double>(a.offset);
  for (const Axis& a : axes) {
    out.put<double>(a.max);
    out.put<double>(a.min);
  }
  out.put<std::uint64_t>(0);  // waveform data
  out.put<std::uint64_t>(0);  // first extended VLR
  out.put<std::uint32_t>(0);  // extended VLR count
  out.put<std::uint64_t>(count);
  out.put<std::uint64_t>(count);  // all first returns
  for (int r = 1; r < 15; ++r) out.put<std::uint64_t>(0);
}

void put_wkt_record(util::ByteWriter& out, const std::string& wkt) {
  const std::string text = wkt + '\0';
  if (text.size() > std::numeric_limits<std::uint16_t>::max())
    throw std::invalid_argument("las: the WKT is longer than a VLR holds");
  out.put<std::uint16_t>(0);  // reserved
  put_text(out, "LASF_Projection", 16);
  out.put<std::uint16_t>(kWktRecordId);
  out.put<std::uint16_t>(static_cast<std::uint16_t>(text.size()));
  put_text(out, "OGC coordinate system WKT", 32);
  out.append(text);
}

// One Extra Bytes descriptor (LAS 1.4 R15, 2.5.2.2): the type, the name,
// no no-data, minimum, maximum, scale or offset, and the description.
void put_extra_bytes_descriptor(util::ByteWriter& out, std::uint8_t data_type,
                                const std::string& name,
                                const std::string& description) {
  out.put<std::uint16_t>(0);  // reserved
  out.put<std::uint8_t>(data_type);
  out.put<std::uint8_t>(0);  // options: none of the optional fields
  put_text(out, name, 32);
  out.append(std::string(4 + 8 + 16 + 8 + 16 + 8 + 16 + 8 + 16 + 8 + 16, '\0'));
  put_text(out, description, 32);
}

void put_extra_bytes_record(util::ByteWriter& out) {
  constexpr std::uint8_t kUchar = 1, kFloat = 9;
  out.put<std::uint16_t>(0);  // reserved
  put_text(out, "LASF_Spec", 16);
  out.put<std::uint16_t>(kExtraBytesRecordId);
  out.put<std::uint16_t>(kExtraBytesFields * kExtraBytesDescriptorSize);
  put_text(out, "Extra Bytes", 32);
  put_extra_bytes_descriptor(out, kUchar, "support",
                             "depth maps that measured it");
  put_extra_bytes_descriptor(out, kFloat, "normal east", "unit normal, ENU");
  put_extra_bytes_descriptor(out, kFloat, "normal north", "unit normal, ENU");
  put_extra_bytes_descriptor(out, kFloat, "normal up", "unit normal, ENU");
  put_extra_bytes_descriptor(out, kUchar, "score",
                             "mean winning ZNCC times 255");
}

void put_point(util::ByteWriter& out, const LasPoint& p,
               const std::array<Axis, 3>& axes, bool extra) {
  for (int a = 0; a < 3; ++a)
    out.put<std::int32_t>(quantize(p.xyz[a], axes[a]));
  out.put<std::uint16_t>(0);    // intensity
  out.put<std::uint8_t>(0x11);  // return 1 of 1
  out.put<std::uint8_t>(0);     // flags, channel, scan direction, edge
  out.put<std::uint8_t>(0);     // classification: never classified
  out.put<std::uint8_t>(0);     // user data
  out.put<std::int16_t>(0);     // scan angle
  out.put<std::uint16_t>(p.source_id);
  out.put<double>(0);  // GPS time
  out.put<std::uint16_t>(p.red);
  out.put<std::uint16_t>(p.green);
  out.put<std::uint16_t>(p.blue);
  if (!extra) return;
  out.put<std::uint8_t>(p.support);
  for (float n : p.normal) out.put<float>(n);
  out.put<std::uint8_t>(p.score);
}

}  // namespace

std::string encode_las(const std::vector<LasPoint>& points,
                       const LasFile& file) {
  std::array<Axis, 3> axes = axes_of(points, file);
  measure_bounds(points, &axes);
  const bool extra =
      std::any_of(points.begin(), points.end(),
                  [](const LasPoint& p) { return p.support > 0; });
  const std::uint32_t point_offset = static_cast<std::uint32_t>(
      kHeaderSize + kVlrHeaderSize + file.wkt.size() + 1 +
      (extra ? kVlrHeaderSize + kExtraBytesFields * kExtraBytesDescriptorSize
             : 0));
  util::ByteWriter out;
  out.reserve(point_offset +
              points.size() * (kPointSize + (extra ? kExtraBytes : 0)));
  put_header(out, file, axes, points.size(), point_offset, extra);
  put_wkt_record(out, file.wkt);
  if (extra) put_extra_bytes_record(out);
  for (const LasPoint& p : points) put_point(out, p, axes, extra);
  return out.take();
}

}  // namespace arscout::viewer
