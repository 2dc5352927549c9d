// The GLB codec of the mesh layer (engine/mesh.h): round trips of every
// attribute and the atlas, the glTF it writes read back here from its JSON
// (not with the codec's own reader), the frame of encode_glb_meshes, and
// clear errors for meshes it cannot write and bytes it cannot read.
#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "arscout/engine/mesh.h"

namespace arscout::engine {
namespace {

using Json = nlohmann::json;

// A wavy 9 x 7 vertex height field with normals, colours, texture
// coordinates and a 64 x 48 gradient atlas.
TexturedMesh wavy_patch(bool textured = true) {
  TexturedMesh mesh;
  constexpr int kNx = 9, kNy = 7;
  for (int j = 0; j < kNy; ++j)
    for (int i = 0; i < kNx; ++i) {
      const float x = 0.5f * i + 100.25f, y = 0.5f * j - 40.5f;
      const float z = 0.3f * std::sin(x) * std::cos(y) + 12;
      mesh.positions.emplace_back(x, y, z);
      const Eigen::Vector3f n(-0.3f * std::cos(x) * std::cos(y),
                              0.3f * std::sin(x) * std::sin(y), 1);
      mesh.normals.push_back(n.normalized());
      mesh.colors.push_back({static_cast<std::uint8_t>(20 * i),
                             static_cast<std::uint8_t>(30 * j), 200});
      if (textured)
        mesh.uvs.emplace_back(i / float(kNx - 1), 1 - j / float(kNy - 1));
    }
  for (int j = 0; j + 1 < kNy; ++j)
    for (int i = 0; i + 1 < kNx; ++i) {
      const std::uint32_t a = j * kNx + i, b = a + 1, c = a + kNx, d = c + 1;
      mesh.indices.insert(mesh.indices.end(), {a, b, d, a, d, c});
    }
  if (textured) {
    mesh.atlas.create(48, 64, CV_8UC3);
    for (int r = 0; r < mesh.atlas.rows; ++r)
      for (int c = 0; c < mesh.atlas.cols; ++c)
        mesh.atlas.at<cv::Vec3b>(r, c) = {static_cast<std::uint8_t>(4 * c),
                                          static_cast<std::uint8_t>(5 * r),
                                          120};
  }
  return mesh;
}

std::uint32_t u32(const std::string& bytes, std::size_t at) {
  std::uint32_t v;
  std::memcpy(&v, bytes.data() + at, 4);
  return v;
}

// A GLB's JSON chunk, parsed.
Json gltf_of(const std::string& glb) {
  return Json::parse(glb.substr(20, u32(glb, 12)));
}

// `glb` with its JSON chunk replaced by `gltf` (the BIN chunk kept).
std::string with_gltf(const std::string& glb, const Json& gltf) {
  std::string json = gltf.dump();
  json.resize((json.size() + 3) / 4 * 4, ' ');
  const std::string rest = glb.substr(20 + u32(glb, 12));
  std::string out(20, '\0');
  const std::uint32_t head[5] = {
      0x46546c67, 2, static_cast<std::uint32_t>(20 + json.size() + rest.size()),
      static_cast<std::uint32_t>(json.size()), 0x4e4f534a};
  std::memcpy(out.data(), head, sizeof head);
  return out + json + rest;
}

// The message of the std::runtime_error decode_glb throws for `bytes`.
std::string decode_error(const std::string& bytes) {
  try {
    decode_glb(bytes);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(Glb, EveryAttributeAndTheAtlasReadBack) {
  const TexturedMesh mesh = wavy_patch();
  const std::string glb = encode_glb(mesh);
  EXPECT_EQ(u32(glb, 0), 0x46546c67u);
  EXPECT_EQ(u32(glb, 4), 2u);
  EXPECT_EQ(u32(glb, 8), glb.size());
  EXPECT_EQ(glb.size() % 4, 0u);
  EXPECT_EQ(u32(glb, 12) % 4, 0u);

  const TexturedMesh back = decode_glb(glb);
  ASSERT_EQ(back.positions.size(), mesh.positions.size());
  for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
    EXPECT_EQ(back.positions[i], mesh.positions[i]) << i;
    EXPECT_EQ(back.normals[i], mesh.normals[i]) << i;
    EXPECT_EQ(back.uvs[i], mesh.uvs[i]) << i;
    EXPECT_EQ(back.colors[i], mesh.colors[i]) << i;
  }
  EXPECT_EQ(back.indices, mesh.indices);
  EXPECT_EQ(back.triangles(), 96u);
  ASSERT_EQ(back.atlas.type(), CV_8UC3);
  ASSERT_EQ(back.atlas.size(), mesh.atlas.size());
  // JPEG at quality 88 on a smooth gradient: within a few levels.
  EXPECT_LT(
      cv::norm(back.atlas, mesh.atlas, cv::NORM_L1) / back.atlas.total() / 3,
      3.0);
}

TEST(Glb, TheGltfIsUnlitWithAnEmbeddedJpegAndBoundedPositions) {
  const TexturedMesh mesh = wavy_patch();
  const Json gltf = gltf_of(encode_glb(mesh));
  EXPECT_EQ(gltf["asset"]["version"], "2.0");
  EXPECT_EQ(gltf["extensionsUsed"], Json::array({"KHR_materials_unlit"}));
  const Json& primitive = gltf["meshes"][0]["primitives"][0];
  EXPECT_EQ(primitive["mode"], 4);
  const Json& attributes = primitive["attributes"];
  // With an atlas the colours are not COLOR_0, which would tint it.
  EXPECT_FALSE(attributes.contains("COLOR_0"));
  ASSERT_TRUE(attributes.contains("_COLOR"));
  const Json& position = gltf["accessors"][attributes["POSITION"].get<int>()];
  EXPECT_EQ(position["componentType"], 5126);
  EXPECT_NEAR(position["min"][0].get<double>(), 100.25, 1e-6);
  EXPECT_NEAR(position["max"][0].get<double>(), 104.25, 1e-6);
  EXPECT_NEAR(position["min"][1].get<double>(), -40.5, 1e-6);
  const Json& indices = gltf["accessors"][primitive["indices"].get<int>()];
  EXPECT_EQ(indices["componentType"], 5125);
  EXPECT_EQ(indices["count"], 288);
  const Json& material = gltf["materials"][primitive["material"].get<int>()];
  EXPECT_TRUE(material["extensions"].contains("KHR_materials_unlit"));
  const int texture =
      material["pbrMetallicRoughness"]["baseColorTexture"]["index"];
  const Json& image =
      gltf["images"][gltf["textures"][texture]["source"].get<int>()];
  EXPECT_EQ(image["mimeType"], "image/jpeg");
  EXPECT_TRUE(image.contains("bufferView"));
  EXPECT_EQ(gltf["samplers"].size(), 1u);
  for (const Json& view : gltf["bufferViews"])
    EXPECT_EQ(view["byteOffset"].get<std::size_t>() % 4, 0u);
}

TEST(Glb, AnUntexturedMeshHasColor0AndNoImage) {
  const TexturedMesh mesh = wavy_patch(false);
  const std::string glb = encode_glb(mesh);
  const Json gltf = gltf_of(glb);
  const Json& attributes = gltf["meshes"][0]["primitives"][0]["attributes"];
  EXPECT_TRUE(attributes.contains("COLOR_0"));
  EXPECT_FALSE(attributes.contains("TEXCOORD_0"));
  EXPECT_FALSE(gltf.contains("images"));
  const TexturedMesh back = decode_glb(glb);
  EXPECT_EQ(back.colors, mesh.colors);
  EXPECT_TRUE(back.uvs.empty());
  EXPECT_TRUE(back.atlas.empty());

  TexturedMesh bare;  // positions and triangles only
  bare.positions = mesh.positions;
  bare.indices = mesh.indices;
  const TexturedMesh bare_back = decode_glb(encode_glb(bare));
  EXPECT_EQ(bare_back.positions, bare.positions);
  EXPECT_EQ(bare_back.indices, bare.indices);
  EXPECT_TRUE(bare_back.normals.empty());
  EXPECT_TRUE(bare_back.colors.empty());
  EXPECT_FALSE(gltf_of(encode_glb(bare)).contains("extensionsUsed"));
}

TEST(Glb, SeveralMeshesTurnedYUpAroundAnOffsetKeepTheirImages) {
  GlbMesh a = decode_glb_mesh(encode_glb(wavy_patch()));
  ASSERT_FALSE(a.image.empty());
  EXPECT_EQ(a.image_mime, "image/jpeg");
  EXPECT_TRUE(a.mesh.atlas.empty());
  GlbMesh b;
  b.mesh = wavy_patch(false);
  GlbFrame frame;
  frame.offset = {100, -40, 10};
  frame.y_up = true;
  const std::string glb = encode_glb_meshes({a, b}, frame);
  const Json gltf = gltf_of(glb);
  ASSERT_EQ(gltf["meshes"][0]["primitives"].size(), 2u);
  EXPECT_EQ(gltf["materials"].size(), 2u);
  EXPECT_EQ(gltf["images"].size(), 1u);
  // The translation is the offset turned: (x, z, -y).
  EXPECT_EQ(gltf["nodes"][0]["translation"], Json::array({100.0, 10.0, 40.0}));
  // Position (x, y, z) - offset is written as (x', z', -y').
  const Json& position =
      gltf["accessors"]
          [gltf["meshes"][0]["primitives"][0]["attributes"]["POSITION"]
               .get<int>()];
  EXPECT_NEAR(position["min"][0].get<double>(), 0.25, 1e-5);
  EXPECT_NEAR(position["max"][2].get<double>(), 0.5, 1e-5);  // -(y + 40) max
  EXPECT_NEAR(position["min"][2].get<double>(), -2.5, 1e-5);
  // The image travels byte for byte: decoding the primitive again finds it.
  const std::size_t view = gltf["images"][0]["bufferView"];
  const std::size_t at = gltf["bufferViews"][view]["byteOffset"];
  const std::size_t bin = 20 + u32(glb, 12) + 8;
  EXPECT_EQ(glb.substr(bin + at, a.image.size()), a.image);
  // One primitive only for the reader.
  EXPECT_NE(decode_error(glb).find("one mesh of one primitive"),
            std::string::npos);
  EXPECT_THROW(encode_glb_meshes({}), std::invalid_argument);
  a.image_mime = "image/webp";
  EXPECT_THROW(encode_glb_meshes({a}), std::invalid_argument);
}

TEST(Glb, MeshesItCannotWriteAreRefused) {
  EXPECT_THROW(encode_glb(TexturedMesh{}), std::invalid_argument);
  TexturedMesh mesh = wavy_patch();
  mesh.indices.push_back(0);  // not whole triangles
  EXPECT_THROW(encode_glb(mesh), std::invalid_argument);
  mesh = wavy_patch();
  mesh.indices[5] = static_cast<std::uint32_t>(mesh.positions.size());
  try {
    encode_glb(mesh);
    FAIL() << "an index past the positions was written";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("past the 63 positions"),
              std::string::npos)
        << e.what();
  }
  mesh = wavy_patch();
  mesh.normals.pop_back();
  EXPECT_THROW(encode_glb(mesh), std::invalid_argument);
  mesh = wavy_patch();
  mesh.uvs.clear();  // an atlas with nothing to map it
  EXPECT_THROW(encode_glb(mesh), std::invalid_argument);
  mesh = wavy_patch();
  mesh.atlas = cv::Mat(48, 64, CV_8UC1, cv::Scalar(7));  // grey
  EXPECT_THROW(encode_glb(mesh), std::invalid_argument);
  mesh = wavy_patch();
  mesh.positions[3].x() = std::nanf("");
  EXPECT_THROW(encode_glb(mesh), std::invalid_argument);
}

TEST(Glb, BadBytesAreRefusedSayingWhatIsWrong) {
  const std::string glb = encode_glb(wavy_patch());
  auto expect = [](const std::string& bytes, const std::string& words) {
    const std::string message = decode_error(bytes);
    EXPECT_EQ(message.rfind("glb: ", 0), 0u) << message;
    EXPECT_NE(message.find(words), std::string::npos)
        << "'" << message << "' does not say '" << words << "'";
  };
  expect("", "too short");
  expect(std::string(64, 'x'), "no 'glTF' magic");
  std::string v1 = glb;
  v1[4] = 1;
  expect(v1, "version 1");
  expect(glb.substr(0, glb.size() - 100), "truncated");
  std::string garbage = glb;
  garbage[20] = '#';
  expect(garbage, "not a JSON object");

  Json gltf = gltf_of(glb);
  Json broken = gltf;
  broken["accessors"][0]["count"] = 100000;
  expect(with_gltf(glb, broken), "runs past");
  broken = gltf;
  broken["meshes"][0]["primitives"][0].erase("indices");
  expect(with_gltf(glb, broken), "not indexed");
  broken = gltf;
  broken["meshes"][0]["primitives"][0]["mode"] = 0;
  expect(with_gltf(glb, broken), "not triangles");
  broken = gltf;
  broken["meshes"][0]["primitives"][0]["attributes"].erase("POSITION");
  expect(with_gltf(glb, broken), "no POSITION");
  broken = gltf;
  broken["accessors"][0]["componentType"] = "float";
  expect(with_gltf(glb, broken), "not as glTF 2.0 has it");
  broken = gltf;
  broken["images"][0].erase("bufferView");
  broken["images"][0]["uri"] = "atlas.jpg";
  expect(with_gltf(glb, broken), "not embedded");
  broken = gltf;
  broken["buffers"][0]["uri"] = "mesh.bin";
  expect(with_gltf(glb, broken), "not the GLB's BIN chunk");
  broken = gltf;
  broken["meshes"] = Json::array();
  expect(with_gltf(glb, broken), "one mesh of one primitive");
  // An atlas that is not an image.
  broken = gltf;
  broken["images"][0]["bufferView"] = 0;  // the positions' bytes
  expect(with_gltf(glb, broken), "does not decode");
}

}  // namespace
}  // namespace arscout::engine
