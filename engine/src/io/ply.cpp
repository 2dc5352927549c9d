#include "arscout/engine/ply.h"

#include <algorithm>
#include <array>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <limits>
#include <optional>
#include <stdexcept>
#include <type_traits>
#include <utility>

#include "arscout/util/file.h"

namespace arscout::engine {
namespace {

constexpr size_t kBytesPerPoint = 15;       // 3 floats + 3 bytes, no padding
constexpr size_t kBytesPerFusedPoint = 29;  // and 3 floats + 2 bytes

[[noreturn]] void fail(const std::string& what) {
  throw std::runtime_error("PLY: " + what);
}

// ---------------------------------------------------------------- writing

void put_float_le(float value, char* out) {
  const uint32_t bits = std::bit_cast<uint32_t>(value);
  for (int i = 0; i < 4; ++i) out[i] = static_cast<char>(bits >> (8 * i));
}

std::string header_text(size_t vertices, std::string_view comment, bool fused) {
  std::string header = "ply\nformat binary_little_endian 1.0\ncomment ";
  header.append(comment);
  header += "\nelement vertex " + std::to_string(vertices) +
            "\nproperty float x\nproperty float y\nproperty float z\n"
            "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  if (fused) {
    header +=
        "property float nx\nproperty float ny\nproperty float nz\n"
        "property uchar support\nproperty uchar score\n";
  }
  return header + "end_header\n";
}

// ---------------------------------------------------------------- header

enum class Format { kAscii, kBinaryLittleEndian };

enum class Type {
  kInt8,
  kUint8,
  kInt16,
  kUint16,
  kInt32,
  kUint32,
  kFloat32,
  kFloat64
};

size_t size_of(Type type) {
  switch (type) {
    case Type::kInt8:
    case Type::kUint8:
      return 1;
    case Type::kInt16:
    case Type::kUint16:
      return 2;
    case Type::kInt32:
    case Type::kUint32:
    case Type::kFloat32:
      return 4;
    case Type::kFloat64:
      return 8;
  }
  return 8;
}

std::optional<Type> parse_type(std::string_view name) {
  static constexpr std::pair<std::string_view, Type> kNames[] = {
      {"char", Type::kInt8},      {"int8", Type::kInt8},
      {"uchar", Type::kUint8},    {"uint8", Type::kUint8},
      {"short", Type::kInt16},    {"int16", Type::kInt16},
      {"ushort", Type::kUint16},  {"uint16", Type::kUint16},
      {"int", Type::kInt32},      {"int32", Type::kInt32},
      {"uint", Type::kUint32},    {"uint32", Type::kUint32},
      {"float", Type::kFloat32},  {"float32", Type::kFloat32},
      {"double", Type::kFloat64}, {"float64", Type::kFloat64}};
  for (const auto& [text, type] : kNames) {
    if (text == name) return type;
  }
  return std::nullopt;
}

bool is_integer(Type type) {
  return type != Type::kFloat32 && type != Type::kFloat64;
}

struct Property {
  std::string name;
  Type type = Type::kFloat32;  // of the items, for a list
  bool is_list = false;
  Type count_type = Type::kUint8;  // lists only
};

struct Element {
  std::string name;
  uint64_t count = 0;
  std::vector<Property> properties;
};

struct Header {
  std::optional<Format> format;
  std::vector<Element> elements;
  size_t body_offset = 0;  // of the first byte after "end_header\n"
};

// Header text is shown in messages; keep it short and printable.
std::string quoted(std::string_view text) {
  std::string out = "'";
  for (char c : text.substr(0, 40)) {
    out += (c >= 0x20 && c < 0x7f) ? c : '?';
  }
  return out + (text.size() > 40 ? "...'" : "'");
}

bool is_space(char c) {
  return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\v' ||
         c == '\f';
}

std::vector<std::string_view> split_words(std::string_view line) {
  std::vector<std::string_view> words;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && is_space(line[i])) ++i;
    const size_t start = i;
    while (i < line.size() && !is_space(line[i])) ++i;
    if (i > start) words.push_back(line.substr(start, i - start));
  }
  return words;
}

// Lines of the header, each without its '\n' (and '\r').
class LineReader {
 public:
  explicit LineReader(std::string_view bytes) : bytes_(bytes) {}

  std::optional<std::string_view> next() {
    const size_t end = bytes_.find('\n', pos_);
    if (end == std::string_view::npos) return std::nullopt;
    std::string_view line = bytes_.substr(pos_, end - pos_);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    pos_ = end + 1;
    return line;
  }
  size_t position() const { return pos_; }

 private:
  std::string_view bytes_;
  size_t pos_ = 0;
};

void parse_format(const std::vector<std::string_view>& words, Header& header) {
  if (header.format) fail("more than one format line");
  if (words.size() != 3) fail("malformed format line");
  if (words[2] != "1.0") fail("unsupported version " + quoted(words[2]));
  if (words[1] == "ascii") {
    header.format = Format::kAscii;
  } else if (words[1] == "binary_little_endian") {
    header.format = Format::kBinaryLittleEndian;
  } else if (words[1] == "binary_big_endian") {
    fail("format binary_big_endian is unsupported");
  } else {
    fail("unknown format " + quoted(words[1]));
  }
}

uint64_t parse_count(std::string_view text, std::string_view element) {
  uint64_t count = 0;
  const auto [end, ec] =
      std::from_chars(text.data(), text.data() + text.size(), count);
  if (ec != std::errc() || end != text.data() + text.size()) {
    fail("element " + quoted(element) + " has a bad count " + quoted(text));
  }
  return count;
}

void parse_element(const std::vector<std::string_view>& words, Header& header) {
  if (words.size() < 2) fail("element line without a name");
  if (words.size() == 2) fail("element " + quoted(words[1]) + " has no count");
  if (words.size() != 3) fail("malformed element line");
  // Only the vertex element must be unique; a set of all names would cost
  // time on hostile headers for no gain.
  if (words[1] == "vertex") {
    for (const Element& element : header.elements) {
      if (element.name == "vertex") fail("element vertex declared twice");
    }
  }
  header.elements.push_back(
      {std::string(words[1]), parse_count(words[2], words[1]), {}});
}

Type parse_type_or_fail(std::string_view name) {
  const std::optional<Type> type = parse_type(name);
  if (!type) fail("unknown property type " + quoted(name));
  return *type;
}

void parse_property(const std::vector<std::string_view>& words,
                    Header& header) {
  if (header.elements.empty()) fail("property before any element");
  Property property;
  if (words.size() == 5 && words[1] == "list") {
    property.is_list = true;
    property.count_type = parse_type_or_fail(words[2]);
    if (!is_integer(property.count_type)) fail("list count is not an integer");
    property.type = parse_type_or_fail(words[3]);
    property.name = words[4];
  } else if (words.size() == 3) {
    property.type = parse_type_or_fail(words[1]);
    property.name = words[2];
  } else {
    fail("malformed property line");
  }
  header.elements.back().properties.push_back(std::move(property));
}

Header parse_header(std::string_view bytes) {
  LineReader lines(bytes);
  const std::optional<std::string_view> magic = lines.next();
  if (!magic || *magic != "ply") fail("not a PLY file (no 'ply' magic)");
  Header header;
  while (const std::optional<std::string_view> line = lines.next()) {
    const std::vector<std::string_view> words = split_words(*line);
    if (words.empty() || words[0] == "comment" || words[0] == "obj_info") {
      continue;
    }
    if (words[0] == "end_header") {
      if (!header.format) fail("no format line");
      header.body_offset = lines.position();
      return header;
    }
    if (words[0] == "format") {
      parse_format(words, header);
    } else if (words[0] == "element") {
      parse_element(words, header);
    } else if (words[0] == "property") {
      parse_property(words, header);
    } else {
      fail("unknown header line " + quoted(*line));
    }
  }
  fail("no end_header");
}

// ---------------------------------------------------------------- body

[[noreturn]] void truncated() { fail("body truncated"); }

// Converts a double to the nearest float, giving an infinity beyond float's
// range instead of the undefined behaviour of a plain cast.
float narrow(double value) {
  constexpr double kMax = std::numeric_limits<float>::max();
  // Half a unit in the last place above FLT_MAX still rounds to FLT_MAX.
  constexpr double kRoundsToInfinity = kMax + 0x1p103;
  if (value >= kRoundsToInfinity) return std::numeric_limits<float>::infinity();
  if (value <= -kRoundsToInfinity) {
    return -std::numeric_limits<float>::infinity();
  }
  return static_cast<float>(value);
}

// Values of a binary_little_endian body, read byte by byte so the host's
// byte order and alignment do not matter.
class BinaryBody {
 public:
  explicit BinaryBody(std::string_view bytes) : bytes_(bytes) {}

  // Whether `count` items of at least `min_size` bytes each can still fit.
  bool could_hold(uint64_t count, uint64_t min_size) const {
    return min_size == 0 || count <= remaining() / min_size;
  }
  size_t remaining() const { return bytes_.size() - pos_; }

  double read(Type type) {
    const uint64_t bits = take(size_of(type));
    switch (type) {
      case Type::kInt8:
        return static_cast<int8_t>(bits);
      case Type::kUint8:
        return static_cast<uint8_t>(bits);
      case Type::kInt16:
        return static_cast<int16_t>(bits);
      case Type::kUint16:
        return static_cast<uint16_t>(bits);
      case Type::kInt32:
        return static_cast<int32_t>(bits);
      case Type::kUint32:
        return static_cast<uint32_t>(bits);
      case Type::kFloat32:
        return std::bit_cast<float>(static_cast<uint32_t>(bits));
      case Type::kFloat64:
        return std::bit_cast<double>(bits);
    }
    return 0;
  }
  // Floats go straight through (no detour via double), keeping every bit.
  float read_float(Type type) {
    if (type == Type::kFloat32) {
      return std::bit_cast<float>(static_cast<uint32_t>(take(4)));
    }
    return narrow(read(type));
  }
  uint8_t read_uchar() { return static_cast<uint8_t>(take(1)); }
  void skip(Type type) { take(size_of(type)); }
  uint64_t read_list_size(Type type) {
    const double n = read(type);
    if (n < 0) fail("negative list size");
    return static_cast<uint64_t>(n);
  }

 private:
  uint64_t take(size_t n) {
    if (bytes_.size() - pos_ < n) truncated();
    uint64_t bits = 0;
    for (size_t i = 0; i < n; ++i) {
      bits |= uint64_t{static_cast<uint8_t>(bytes_[pos_ + i])} << (8 * i);
    }
    pos_ += n;
    return bits;
  }

  std::string_view bytes_;
  size_t pos_ = 0;
};

// Values of an ascii body: numbers separated by any white space (line
// breaks between elements are conventional, not required).
class AsciiBody {
 public:
  explicit AsciiBody(std::string_view text) : text_(text) {}

  // Each item is at least one character and one separator, but the very
  // last needs no separator.
  bool could_hold(uint64_t count, uint64_t min_values) const {
    return min_values == 0 || count <= (remaining() + 1) / (2 * min_values);
  }
  size_t remaining() const { return text_.size() - pos_; }

  double read(Type) { return parse<double>(token()); }
  float read_float(Type type) {
    const std::string_view text = token();
    if (type != Type::kFloat32) return narrow(parse<double>(text));
    // Straight to float: via double would round twice.
    std::optional<float> value = try_parse<float>(text);
    return value ? *value : narrow(parse<double>(text));
  }
  uint8_t read_uchar() {
    const std::string_view text = token();
    const std::optional<int> value = try_parse<int>(text);
    if (!value || *value < 0 || *value > 255) {
      fail("colour value " + quoted(text) + " is not in 0..255");
    }
    return static_cast<uint8_t>(*value);
  }
  void skip(Type type) { read(type); }
  uint64_t read_list_size(Type) {
    const std::string_view text = token();
    const std::optional<uint64_t> n = try_parse<uint64_t>(text);
    if (!n) fail("bad list size " + quoted(text));
    return *n;
  }

 private:
  std::string_view token() {
    while (pos_ < text_.size() && is_space(text_[pos_])) ++pos_;
    if (pos_ == text_.size()) truncated();
    const size_t start = pos_;
    while (pos_ < text_.size() && !is_space(text_[pos_])) ++pos_;
    return text_.substr(start, pos_ - start);
  }

  // The whole token as a number, or nullopt (also when out of range).
  template <class T>
  static std::optional<T> try_parse(std::string_view text) {
    if (!text.empty() && text[0] == '+') text.remove_prefix(1);
    T value{};
    const auto [end, ec] =
        std::from_chars(text.data(), text.data() + text.size(), value);
    if (ec != std::errc() || end != text.data() + text.size()) {
      return std::nullopt;
    }
    return value;
  }
  template <class T>
  static T parse(std::string_view text) {
    const std::optional<T> value = try_parse<T>(text);
    if (!value) fail("not a number: " + quoted(text));
    return *value;
  }

  std::string_view text_;
  size_t pos_ = 0;
};

// What each vertex property is for.
enum class Role {
  kSkip,
  kX,
  kY,
  kZ,
  kRed,
  kGreen,
  kBlue,
  kNx,
  kNy,
  kNz,
  kSupport,
  kScore
};

Role role_of(const Property& property) {
  static constexpr std::pair<std::string_view, Role> kRoles[] = {
      {"x", Role::kX},         {"y", Role::kY},
      {"z", Role::kZ},         {"red", Role::kRed},
      {"green", Role::kGreen}, {"blue", Role::kBlue},
      {"nx", Role::kNx},       {"ny", Role::kNy},
      {"nz", Role::kNz},       {"support", Role::kSupport},
      {"score", Role::kScore}};
  for (const auto& [name, role] : kRoles) {
    if (property.name == name) return role;
  }
  return Role::kSkip;
}

std::vector<Role> vertex_roles(const Element& vertex) {
  std::vector<Role> roles;
  std::array<int, 12> seen{};
  for (const Property& property : vertex.properties) {
    if (property.is_list) {
      fail("list property " + quoted(property.name) + " in element vertex");
    }
    const Role role = role_of(property);
    if (role != Role::kSkip && seen[static_cast<int>(role)]++) {
      fail("vertex property " + quoted(property.name) + " declared twice");
    }
    if (role >= Role::kRed && role <= Role::kBlue &&
        property.type != Type::kUint8) {
      fail("vertex property " + quoted(property.name) + " is not a uchar");
    }
    if ((role == Role::kSupport || role == Role::kScore) &&
        !is_integer(property.type)) {
      fail("vertex property " + quoted(property.name) + " is not an integer");
    }
    roles.push_back(role);
  }
  for (Role role : {Role::kX, Role::kY, Role::kZ}) {
    if (!seen[static_cast<int>(role)]) fail("vertex lacks x, y or z");
  }
  return roles;
}

// Minimal bytes (binary) or values (ascii) one instance of `element` takes.
template <class Body>
uint64_t min_item_size(const Element& element) {
  uint64_t size = 0;
  for (const Property& property : element.properties) {
    if constexpr (std::is_same_v<Body, BinaryBody>) {
      size += size_of(property.is_list ? property.count_type : property.type);
    } else {
      size += 1;
    }
  }
  return size;
}

template <class Body>
void check_count(const Body& body, const Element& element) {
  if (!body.could_hold(element.count, min_item_size<Body>(element))) {
    fail("body truncated (or count impossible): " +
         std::to_string(element.count) + " " + quoted(element.name) +
         " elements cannot fit in the " + std::to_string(body.remaining()) +
         " bytes left");
  }
}

template <class Body>
void skip_element(Body& body, const Element& element) {
  check_count(body, element);
  if (element.properties.empty()) return;  // nothing to read, however many
  for (uint64_t i = 0; i < element.count; ++i) {
    for (const Property& property : element.properties) {
      if (!property.is_list) {
        body.skip(property.type);
        continue;
      }
      const uint64_t n = body.read_list_size(property.count_type);
      // Bounds the loop below by the body size, whatever n claims.
      if (!body.could_hold(n, 1)) truncated();
      for (uint64_t k = 0; k < n; ++k) body.skip(property.type);
    }
  }
}

// Ascii bodies parse every number as a double, "nan" included.
uint8_t clamp_byte(double value) {
  if (!(value > 0)) return 0;
  return static_cast<uint8_t>(std::min(value, 255.0));
}

template <class Body>
ColoredPoint read_vertex(Body& body, const Element& vertex,
                         const std::vector<Role>& roles) {
  ColoredPoint point;
  for (size_t j = 0; j < roles.size(); ++j) {
    const Type type = vertex.properties[j].type;
    // clang-format off
    switch (roles[j]) {
      case Role::kX: point.x = body.read_float(type); break;
      case Role::kY: point.y = body.read_float(type); break;
      case Role::kZ: point.z = body.read_float(type); break;
      case Role::kRed: point.r = body.read_uchar(); break;
      case Role::kGreen: point.g = body.read_uchar(); break;
      case Role::kBlue: point.b = body.read_uchar(); break;
      case Role::kNx: point.nx = body.read_float(type); break;
      case Role::kNy: point.ny = body.read_float(type); break;
      case Role::kNz: point.nz = body.read_float(type); break;
      case Role::kSupport: point.support = clamp_byte(body.read(type)); break;
      case Role::kScore: point.score = clamp_byte(body.read(type)); break;
      case Role::kSkip: body.skip(type); break;
    }
    // clang-format on
  }
  return point;
}

template <class Body>
std::vector<ColoredPoint> decode_body(Body body, const Header& header) {
  for (const Element& element : header.elements) {
    if (element.name != "vertex") {
      skip_element(body, element);
      continue;
    }
    const std::vector<Role> roles = vertex_roles(element);
    check_count(body, element);  // before reserving: counts are untrusted
    std::vector<ColoredPoint> points;
    points.reserve(element.count);
    for (uint64_t i = 0; i < element.count; ++i) {
      points.push_back(read_vertex(body, element, roles));
    }
    return points;  // whatever follows is not ours to check
  }
  fail("no vertex element");
}

}  // namespace

std::string encode_ply(const std::vector<ColoredPoint>& points,
                       std::string_view comment) {
  if (comment.find_first_of("\r\n") != std::string_view::npos) {
    throw std::invalid_argument("PLY comment holds a line break");
  }
  const bool fused =
      std::any_of(points.begin(), points.end(),
                  [](const ColoredPoint& p) { return p.support > 0; });
  std::string bytes = header_text(points.size(), comment, fused);
  const size_t start = bytes.size();
  const size_t stride = fused ? kBytesPerFusedPoint : kBytesPerPoint;
  bytes.resize(start + points.size() * stride);
  char* out = bytes.data() + start;
  for (const ColoredPoint& p : points) {
    put_float_le(p.x, out);
    put_float_le(p.y, out + 4);
    put_float_le(p.z, out + 8);
    out[12] = static_cast<char>(p.r);
    out[13] = static_cast<char>(p.g);
    out[14] = static_cast<char>(p.b);
    if (fused) {
      put_float_le(p.nx, out + 15);
      put_float_le(p.ny, out + 19);
      put_float_le(p.nz, out + 23);
      out[27] = static_cast<char>(p.support);
      out[28] = static_cast<char>(p.score);
    }
    out += stride;
  }
  return bytes;
}

void write_ply(const std::string& path, const std::vector<ColoredPoint>& points,
               std::string_view comment) {
  util::write_file_atomic(path, encode_ply(points, comment));
}

std::vector<ColoredPoint> decode_ply(std::string_view bytes) {
  const Header header = parse_header(bytes);
  const std::string_view body = bytes.substr(header.body_offset);
  if (header.format == Format::kAscii) {
    return decode_body(AsciiBody(body), header);
  }
  return decode_body(BinaryBody(body), header);
}

std::vector<ColoredPoint> read_ply(const std::string& path) {
  const std::string bytes = util::read_file(path);
  try {
    return decode_ply(bytes);
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(path + ": " + e.what());
  }
}

}  // namespace arscout::engine
