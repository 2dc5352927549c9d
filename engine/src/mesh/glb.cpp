// Textured meshes as binary glTF 2.0 (GLB): the writer (one primitive per
// mesh, an unlit material per atlas) and a reader of one indexed triangle
// primitive. Layout: the 12-byte header, the JSON chunk (padded with
// spaces) and the BIN chunk (padded with zeros), both 4-byte aligned; in
// BIN one buffer view per accessor or image, each starting on 4 bytes.
#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string_view>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "arscout/engine/mesh.h"
#include "arscout/util/bytes.h"

namespace arscout::engine {
namespace {

using Json = nlohmann::json;

constexpr std::uint32_t kGlbMagic = 0x46546c67;  // "glTF"
constexpr std::uint32_t kJsonChunk = 0x4e4f534a;
constexpr std::uint32_t kBinChunk = 0x004e4942;
constexpr int kByte = 5120, kUnsignedByte = 5121, kShort = 5122,
              kUnsignedShort = 5123, kUnsignedInt = 5125, kFloat = 5126;
constexpr int kArrayBuffer = 34962, kElementArrayBuffer = 34963;
constexpr int kTriangles = 4;
constexpr int kLinear = 9729, kLinearMipmapLinear = 9987, kClampToEdge = 33071;
constexpr const char* kUnlit = "KHR_materials_unlit";
constexpr const char* kUntexturedColor = "_COLOR";

// Arrays go into BIN and come out of it as they lie in memory: glTF's
// little-endian layout on the hosts arscout runs on (x86-64, ARM).
static_assert(std::endian::native == std::endian::little,
              "the GLB codec copies arrays as little-endian memory");

// ---------------------------------------------------------------------------
// Writing.

// One primitive to write: a mesh and its atlas as an image file.
struct Part {
  const TexturedMesh* mesh;
  std::string_view image;
  std::string_view mime;
};

[[noreturn]] void invalid(const std::string& what) {
  throw std::invalid_argument("glb: " + what);
}

void check_mesh(const TexturedMesh& mesh) {
  const std::size_t n = mesh.positions.size();
  if (mesh.indices.empty()) invalid("the mesh has no triangles");
  if (mesh.indices.size() % 3 != 0)
    invalid(std::to_string(mesh.indices.size()) +
            " indices are not whole triangles");
  auto sized = [n](std::size_t size) { return size == 0 || size == n; };
  if (!sized(mesh.normals.size()) || !sized(mesh.colors.size()) ||
      !sized(mesh.uvs.size()))
    invalid(
        "normals, colours and texture coordinates must be empty or one "
        "per position (" +
        std::to_string(n) + ")");
  for (std::uint32_t i : mesh.indices)
    if (i >= n)
      invalid("index " + std::to_string(i) + " is past the " +
              std::to_string(n) + " positions");
  for (const Eigen::Vector3f& p : mesh.positions)
    if (!p.allFinite()) invalid("a position is not finite");
}

void check_part(const Part& part) {
  check_mesh(*part.mesh);
  if (part.image.empty()) return;
  if (part.mime != "image/jpeg" && part.mime != "image/png")
    invalid("the atlas's MIME type '" + std::string(part.mime) +
            "' is neither image/jpeg nor image/png");
  if (part.mesh->uvs.empty())
    invalid("a mesh with an atlas needs texture coordinates");
}

std::string jpeg_of(const cv::Mat& atlas, int quality) {
  if (atlas.empty()) return {};
  if (atlas.type() != CV_8UC3) invalid("the atlas must be CV_8UC3 (BGR)");
  std::vector<unsigned char> bytes;
  if (!cv::imencode(".jpg", atlas, bytes,
                    {cv::IMWRITE_JPEG_QUALITY, std::clamp(quality, 1, 100)}))
    throw std::runtime_error("glb: the atlas did not encode as JPEG");
  return std::string(bytes.begin(), bytes.end());
}

// The site frame's z up into glTF's y up, or nothing.
Eigen::Matrix3d frame_rotation(const GlbFrame& frame) {
  Eigen::Matrix3d r = Eigen::Matrix3d::Identity();
  if (frame.y_up) r << 1, 0, 0, 0, 0, 1, 0, -1, 0;
  return r;
}

// Collects buffer views, accessors, materials and images, and the BIN
// chunk they point into; finish() gives the GLB.
class GlbBuilder {
 public:
  explicit GlbBuilder(const GlbFrame& frame)
      : rotation_(frame_rotation(frame)), offset_(frame.offset) {}

  void add(const Part& part) {
    check_part(part);
    const TexturedMesh& mesh = *part.mesh;
    Json primitive = {{"attributes", attributes_of(mesh, !part.image.empty())},
                      {"mode", kTriangles}};
    primitive["indices"] =
        accessor(view(raw(mesh.indices), kElementArrayBuffer), kUnsignedInt,
                 mesh.indices.size(), "SCALAR");
    primitive["material"] = material_of(part, !mesh.colors.empty());
    primitives_.push_back(std::move(primitive));
  }

  std::string finish() const;

 private:
  template <typename T>
  static std::string_view raw(const std::vector<T>& values) {
    return {reinterpret_cast<const char*>(values.data()),
            values.size() * sizeof(T)};
  }

  // The view of `bytes` appended to BIN (on 4 bytes), its index.
  std::size_t view(std::string_view bytes, int target = 0) {
    Json v = {{"buffer", 0},
              {"byteOffset", bin_.size()},
              {"byteLength", bytes.size()}};
    if (target) v["target"] = target;
    bin_.append(bytes);
    while (bin_.size() % 4) bin_.put<std::uint8_t>(0);
    views_.push_back(std::move(v));
    return views_.size() - 1;
  }

  std::size_t accessor(std::size_t view, int component, std::size_t count,
                       const char* type, bool normalized = false) {
    Json a = {{"bufferView", view},
              {"componentType", component},
              {"count", count},
              {"type", type}};
    if (normalized) a["normalized"] = true;
    accessors_.push_back(std::move(a));
    return accessors_.size() - 1;
  }

  Json attributes_of(const TexturedMesh& mesh, bool textured);
  std::size_t material_of(const Part& part, bool coloured);

  Eigen::Matrix3d rotation_;
  Eigen::Vector3d offset_;
  util::ByteWriter bin_;
  Json views_ = Json::array(), accessors_ = Json::array(),
       primitives_ = Json::array(), materials_ = Json::array(),
       textures_ = Json::array(), images_ = Json::array();
};

Json GlbBuilder::attributes_of(const TexturedMesh& mesh, bool textured) {
  const std::size_t n = mesh.positions.size();
  std::vector<float> xyz;
  xyz.reserve(3 * n);
  Eigen::Vector3f lo =
      Eigen::Vector3f::Constant(std::numeric_limits<float>::max());
  Eigen::Vector3f hi = -lo;
  for (const Eigen::Vector3f& p : mesh.positions) {
    const Eigen::Vector3f q =
        (rotation_ * (p.cast<double>() - offset_)).cast<float>();
    lo = lo.cwiseMin(q);
    hi = hi.cwiseMax(q);
    xyz.insert(xyz.end(), {q.x(), q.y(), q.z()});
  }
  Json attributes;
  attributes["POSITION"] =
      accessor(view(raw(xyz), kArrayBuffer), kFloat, n, "VEC3");
  accessors_.back()["min"] = {lo.x(), lo.y(), lo.z()};
  accessors_.back()["max"] = {hi.x(), hi.y(), hi.z()};
  if (!mesh.normals.empty()) {
    xyz.clear();
    for (const Eigen::Vector3f& v : mesh.normals) {
      const Eigen::Vector3f q = (rotation_ * v.cast<double>()).cast<float>();
      xyz.insert(xyz.end(), {q.x(), q.y(), q.z()});
    }
    attributes["NORMAL"] =
        accessor(view(raw(xyz), kArrayBuffer), kFloat, n, "VEC3");
  }
  if (!mesh.colors.empty()) {
    std::vector<std::uint8_t> rgba;
    rgba.reserve(4 * n);
    for (const auto& c : mesh.colors)
      rgba.insert(rgba.end(), {c[0], c[1], c[2], 255});
    attributes[textured ? kUntexturedColor : "COLOR_0"] =
        accessor(view(raw(rgba), kArrayBuffer), kUnsignedByte, n, "VEC4", true);
  }
  if (!mesh.uvs.empty()) {
    std::vector<float> uv;
    uv.reserve(2 * n);
    for (const Eigen::Vector2f& t : mesh.uvs)
      uv.insert(uv.end(), {t.x(), t.y()});
    attributes["TEXCOORD_0"] =
        accessor(view(raw(uv), kArrayBuffer), kFloat, n, "VEC2");
  }
  return attributes;
}

// An unlit material when there is an atlas or colours (the photos hold the
// light), a plain matte one otherwise.
std::size_t GlbBuilder::material_of(const Part& part, bool coloured) {
  Json pbr = {{"baseColorFactor", {1.0, 1.0, 1.0, 1.0}},
              {"metallicFactor", 0.0},
              {"roughnessFactor", 1.0}};
  if (!part.image.empty()) {
    images_.push_back(
        {{"bufferView", view(part.image)}, {"mimeType", part.mime}});
    textures_.push_back({{"sampler", 0}, {"source", images_.size() - 1}});
    pbr["baseColorTexture"] = {{"index", textures_.size() - 1}};
  }
  Json material = {{"pbrMetallicRoughness", std::move(pbr)}};
  if (!part.image.empty() || coloured)
    material["extensions"] = {{kUnlit, Json::object()}};
  materials_.push_back(std::move(material));
  return materials_.size() - 1;
}

std::string GlbBuilder::finish() const {
  Json node = {{"mesh", 0}};
  const Eigen::Vector3d t = rotation_ * offset_;
  if (!t.isZero()) node["translation"] = {t.x(), t.y(), t.z()};
  Json gltf = {{"asset", {{"version", "2.0"}, {"generator", "arscout"}}},
               {"scene", 0},
               {"scenes", {{{"nodes", {0}}}}},
               {"nodes", {node}},
               {"meshes", {{{"primitives", primitives_}}}},
               {"accessors", accessors_},
               {"bufferViews", views_},
               {"buffers", {{{"byteLength", bin_.size()}}}},
               {"materials", materials_}};
  const bool unlit =
      std::any_of(materials_.begin(), materials_.end(),
                  [](const Json& m) { return m.contains("extensions"); });
  if (unlit) gltf["extensionsUsed"] = {kUnlit};
  if (!images_.empty()) {
    gltf["images"] = images_;
    gltf["textures"] = textures_;
    gltf["samplers"] = {{{"magFilter", kLinear},
                         {"minFilter", kLinearMipmapLinear},
                         {"wrapS", kClampToEdge},
                         {"wrapT", kClampToEdge}}};
  }
  std::string json = gltf.dump();
  json.resize((json.size() + 3) / 4 * 4, ' ');
  const std::string& bin = bin_.bytes();
  util::ByteWriter glb;
  glb.reserve(28 + json.size() + bin.size());
  glb.put<std::uint32_t>(kGlbMagic);
  glb.put<std::uint32_t>(2);
  glb.put<std::uint32_t>(
      static_cast<std::uint32_t>(28 + json.size() + bin.size()));
  glb.put<std::uint32_t>(static_cast<std::uint32_t>(json.size()));
  glb.put<std::uint32_t>(kJsonChunk);
  glb.append(json);
  glb.put<std::uint32_t>(static_cast<std::uint32_t>(bin.size()));
  glb.put<std::uint32_t>(kBinChunk);
  glb.append(bin);
  return glb.take();
}

std::string encode_parts(const std::vector<Part>& parts,
                         const GlbFrame& frame) {
  if (parts.empty()) invalid("no meshes to write");
  GlbBuilder builder(frame);
  for (const Part& part : parts) builder.add(part);
  return builder.finish();
}

// ---------------------------------------------------------------------------
// Reading.

[[noreturn]] void bad(const std::string& what) {
  throw std::runtime_error("glb: " + what);
}

struct Glb {
  Json gltf;
  std::string_view bin;
};

Glb split_glb(const std::string& bytes) {
  util::ByteReader in(bytes, "glb: ");
  if (bytes.size() < 20)
    in.fail("too short for a GLB header (" + std::to_string(bytes.size()) +
            " bytes)");
  if (in.get<std::uint32_t>() != kGlbMagic)
    in.fail("not a GLB (no 'glTF' magic)");
  const auto version = in.get<std::uint32_t>();
  if (version != 2)
    in.fail("GLB version " + std::to_string(version) + ", not 2");
  if (in.get<std::uint32_t>() != bytes.size())
    in.fail("the header's length is not the file's (" +
            std::to_string(bytes.size()) + " bytes): truncated?");
  const auto json_size = in.get<std::uint32_t>();
  if (in.get<std::uint32_t>() != kJsonChunk)
    in.fail("the first chunk is not JSON");
  if (json_size > in.left()) in.fail("the JSON chunk runs past the end");
  Glb glb;
  const std::string_view json = in.take(json_size);
  glb.gltf = Json::parse(json.begin(), json.end(), nullptr, false);
  if (glb.gltf.is_discarded() || !glb.gltf.is_object())
    in.fail("the JSON chunk is not a JSON object");
  if (!in.done()) {  // the BIN chunk; later chunks (none defined) ignored
    if (in.left() < 8) in.fail("a chunk header is cut short");
    const auto bin_size = in.get<std::uint32_t>();
    if (in.get<std::uint32_t>() != kBinChunk)
      in.fail("the second chunk is not BIN");
    if (bin_size > in.left()) in.fail("the BIN chunk runs past the end");
    glb.bin = in.take(bin_size);
  }
  return glb;
}

int components_of(const std::string& type) {
  if (type == "SCALAR") return 1;
  if (type == "VEC2") return 2;
  if (type == "VEC3") return 3;
  if (type == "VEC4") return 4;
  return 0;
}

std::size_t component_size(int type) {
  switch (type) {
    case kByte:
    case kUnsignedByte:
      return 1;
    case kShort:
    case kUnsignedShort:
      return 2;
    case kUnsignedInt:
    case kFloat:
      return 4;
    default:
      return 0;
  }
}

// One accessor's elements in BIN, checked to lie within its view.
struct AccessorView {
  const char* data = nullptr;
  std::size_t count = 0, stride = 0;
  int component = 0, components = 0;
  bool normalized = false;

  // Element i's component c; a normalized integer as [0, 1] (unsigned) or
  // [-1, 1] (signed).
  double get(std::size_t i, int c) const;
};

template <typename T>
T read_raw(const char* at) {
  T value;
  std::memcpy(&value, at, sizeof value);
  return value;
}

double AccessorView::get(std::size_t i, int c) const {
  const char* at = data + i * stride + c * component_size(component);
  switch (component) {
    case kFloat:
      return read_raw<float>(at);
    case kUnsignedInt:
      return read_raw<std::uint32_t>(at);
    case kUnsignedByte: {
      const double v = read_raw<std::uint8_t>(at);
      return normalized ? v / 255 : v;
    }
    case kUnsignedShort: {
      const double v = read_raw<std::uint16_t>(at);
      return normalized ? v / 65535 : v;
    }
    case kByte: {
      const double v = read_raw<std::int8_t>(at);
      return normalized ? std::max(v / 127, -1.0) : v;
    }
    default: {
      const double v = read_raw<std::int16_t>(at);
      return normalized ? std::max(v / 32767, -1.0) : v;
    }
  }
}

AccessorView accessor_view(const Glb& glb, const Json& index,
                           const std::string& what) {
  const Json& accessors = glb.gltf.value("accessors", Json::array());
  if (!index.is_number_unsigned() ||
      index.get<std::size_t>() >= accessors.size())
    bad(what + ": no such accessor");
  const Json& a = accessors[index.get<std::size_t>()];
  if (a.contains("sparse")) bad(what + ": sparse accessors are not read");
  if (!a.contains("bufferView"))
    bad(what + ": the accessor has no buffer view");
  AccessorView out;
  out.component = a.at("componentType").get<int>();
  out.components = components_of(a.at("type").get<std::string>());
  out.count = a.at("count").get<std::size_t>();
  out.normalized = a.value("normalized", false);
  const std::size_t element = component_size(out.component) * out.components;
  if (element == 0) bad(what + ": unknown component or accessor type");
  const Json& views = glb.gltf.value("bufferViews", Json::array());
  const std::size_t v = a.at("bufferView").get<std::size_t>();
  if (v >= views.size()) bad(what + ": no such buffer view");
  const Json& view = views[v];
  if (view.value("buffer", 0) != 0) bad(what + ": not in the GLB's BIN chunk");
  const std::size_t start = view.value("byteOffset", std::size_t{0});
  const std::size_t length = view.at("byteLength").get<std::size_t>();
  const std::size_t at = a.value("byteOffset", std::size_t{0});
  out.stride = view.value("byteStride", element);
  if (start > glb.bin.size() || length > glb.bin.size() - start)
    bad(what + ": the buffer view runs past the BIN chunk");
  if (out.count > 0 && (out.stride < element || at > length ||
                        (out.count - 1) * out.stride + element > length - at))
    bad(what + ": the accessor runs past its buffer view");
  out.data = glb.bin.data() + start + at;
  return out;
}

// The attribute `name` of `primitive` as vectors of `N` floats, or none.
template <int N>
std::vector<Eigen::Matrix<float, N, 1>> read_vectors(const Glb& glb,
                                                     const Json& primitive,
                                                     const char* name,
                                                     std::size_t count) {
  std::vector<Eigen::Matrix<float, N, 1>> out;
  const Json& attributes = primitive.at("attributes");
  if (!attributes.contains(name)) return out;
  const AccessorView a = accessor_view(glb, attributes.at(name), name);
  if (a.components != N || a.count != count)
    bad(std::string(name) + ": " + std::to_string(a.count) + " elements of " +
        std::to_string(a.components) + " components, expected " +
        std::to_string(count) + " of " + std::to_string(N));
  out.resize(count);
  for (std::size_t i = 0; i < count; ++i)
    for (int c = 0; c < N; ++c) out[i][c] = static_cast<float>(a.get(i, c));
  return out;
}

std::vector<std::array<std::uint8_t, 3>> read_colors(const Glb& glb,
                                                     const Json& primitive,
                                                     std::size_t count) {
  std::vector<std::array<std::uint8_t, 3>> out;
  const Json& attributes = primitive.at("attributes");
  const char* name =
      attributes.contains(kUntexturedColor) ? kUntexturedColor : "COLOR_0";
  if (!attributes.contains(name)) return out;
  const AccessorView a = accessor_view(glb, attributes.at(name), name);
  const bool unit = a.component == kFloat || a.normalized;
  if ((a.components != 3 && a.components != 4) || a.count != count || !unit)
    bad(std::string(name) + ": not one RGB(A) colour per position");
  out.resize(count);
  for (std::size_t i = 0; i < count; ++i)
    for (int c = 0; c < 3; ++c)
      out[i][c] = static_cast<std::uint8_t>(
          std::lround(std::clamp(a.get(i, c), 0.0, 1.0) * 255));
  return out;
}

std::vector<std::uint32_t> read_indices(const Glb& glb, const Json& primitive,
                                        std::size_t vertices) {
  if (!primitive.contains("indices")) bad("the primitive is not indexed");
  const AccessorView a = accessor_view(glb, primitive.at("indices"), "indices");
  if (a.components != 1 || a.component == kFloat || a.component == kByte ||
      a.component == kShort)
    bad("indices: not unsigned integers");
  if (a.count == 0 || a.count % 3 != 0)
    bad("indices: " + std::to_string(a.count) + " are not whole triangles");
  std::vector<std::uint32_t> out(a.count);
  for (std::size_t i = 0; i < a.count; ++i) {
    out[i] = static_cast<std::uint32_t>(a.get(i, 0));
    if (out[i] >= vertices)
      bad("index " + std::to_string(out[i]) + " is past the " +
          std::to_string(vertices) + " positions");
  }
  return out;
}

// The image of the primitive's base colour texture, with its MIME type.
void read_image(const Glb& glb, const Json& primitive, GlbMesh* out) {
  if (!primitive.contains("material")) return;
  const Json& material =
      glb.gltf.at("materials").at(primitive.at("material").get<std::size_t>());
  const Json pbr = material.value("pbrMetallicRoughness", Json::object());
  if (!pbr.contains("baseColorTexture")) return;
  const Json& texture =
      glb.gltf.at("textures")
          .at(pbr.at("baseColorTexture").at("index").get<std::size_t>());
  const Json& image =
      glb.gltf.at("images").at(texture.at("source").get<std::size_t>());
  if (!image.contains("bufferView"))
    bad("the atlas is not embedded (an image uri is not read)");
  const Json& view =
      glb.gltf.at("bufferViews").at(image.at("bufferView").get<std::size_t>());
  const std::size_t start = view.value("byteOffset", std::size_t{0});
  const std::size_t length = view.at("byteLength").get<std::size_t>();
  if (view.value("buffer", 0) != 0 || start > glb.bin.size() ||
      length > glb.bin.size() - start)
    bad("the atlas's buffer view runs past the BIN chunk");
  out->image = std::string(glb.bin.substr(start, length));
  out->image_mime = image.value("mimeType", std::string());
}

GlbMesh read_mesh(const Glb& glb) {
  const Json& meshes = glb.gltf.value("meshes", Json::array());
  if (meshes.size() != 1 ||
      meshes[0].value("primitives", Json::array()).size() != 1)
    bad("expected one mesh of one primitive");
  const Json& buffers = glb.gltf.value("buffers", Json::array());
  if (buffers.empty() || buffers[0].contains("uri"))
    bad("the buffer is not the GLB's BIN chunk");
  const Json& primitive = meshes[0].at("primitives")[0];
  if (primitive.value("mode", kTriangles) != kTriangles)
    bad("the primitive is not triangles");
  if (!primitive.at("attributes").contains("POSITION"))
    bad("the primitive has no POSITION");
  const AccessorView p =
      accessor_view(glb, primitive.at("attributes").at("POSITION"), "POSITION");
  if (p.component != kFloat || p.components != 3)
    bad("POSITION: not float VEC3");
  GlbMesh out;
  TexturedMesh& mesh = out.mesh;
  mesh.positions = read_vectors<3>(glb, primitive, "POSITION", p.count);
  mesh.normals = read_vectors<3>(glb, primitive, "NORMAL", p.count);
  mesh.uvs = read_vectors<2>(glb, primitive, "TEXCOORD_0", p.count);
  mesh.colors = read_colors(glb, primitive, p.count);
  mesh.indices = read_indices(glb, primitive, p.count);
  read_image(glb, primitive, &out);
  return out;
}

}  // namespace

std::string encode_glb(const TexturedMesh& mesh, int jpeg_quality) {
  check_mesh(mesh);
  if (!mesh.atlas.empty() && mesh.uvs.empty())
    invalid("a mesh with an atlas needs texture coordinates");
  const std::string jpeg = jpeg_of(mesh.atlas, jpeg_quality);
  return encode_parts({{&mesh, jpeg, "image/jpeg"}}, {});
}

std::string encode_glb_meshes(const std::vector<GlbMesh>& meshes,
                              const GlbFrame& frame) {
  std::vector<Part> parts;
  parts.reserve(meshes.size());
  for (const GlbMesh& m : meshes)
    parts.push_back({&m.mesh, m.image, m.image_mime});
  return encode_parts(parts, frame);
}

std::string encode_atlas_jpeg(const cv::Mat& atlas, int jpeg_quality) {
  return jpeg_of(atlas, jpeg_quality);
}

GlbMesh decode_glb_mesh(const std::string& bytes) {
  const Glb glb = split_glb(bytes);
  try {
    return read_mesh(glb);
  } catch (const Json::exception& e) {
    bad(std::string("the glTF JSON is not as glTF 2.0 has it: ") + e.what());
  }
}

TexturedMesh decode_glb(const std::string& bytes) {
  GlbMesh glb = decode_glb_mesh(bytes);
  if (!glb.image.empty()) {
    const std::vector<unsigned char> file(glb.image.begin(), glb.image.end());
    glb.mesh.atlas = cv::imdecode(file, cv::IMREAD_COLOR);
    if (glb.mesh.atlas.empty())
      bad("the atlas (" + glb.image_mime + ", " +
          std::to_string(glb.image.size()) + " bytes) does not decode");
  }
  return std::move(glb.mesh);
}

}  // namespace arscout::engine
