// obj: the textured mesh as Wavefront OBJ in a zip: SITE/model.obj (every
// mesh tile's finest level as a group of its own, its material named
// after the tile), SITE/model.mtl and each tile's atlas as the image it was
// stored as (SITE/tile_IX_IY.jpg). In the site frame (ENU metres, z up;
// docs/mesh.md, "Exports"); a tile without an atlas carries its vertex
// colours as "v x y z r g b", which MeshLab and Blender read.
#include <charconv>

#include "export_support.h"
#include "zip_writer.h"

namespace arscout::viewer::formats {

extern const Exporter obj;

namespace {

// Numbers as the shortest text that reads back to the same float.
void obj_number(std::string* out, float value) {
  char text[32];
  const auto end = std::to_chars(text, text + sizeof text, value).ptr;
  out->push_back(' ');
  out->append(text, end);
}

void obj_line(std::string* out, const char* tag,
              std::initializer_list<float> values) {
  out->append(tag);
  for (float v : values) obj_number(out, v);
  out->push_back('\n');
}

// Counts of what model.obj holds so far: OBJ numbers v, vt and vn across
// the whole file from 1.
struct ObjCounts {
  std::size_t v = 0, vt = 0, vn = 0;
};

void obj_face_corner(std::string* out, std::uint32_t i, const ObjCounts& base,
                     bool uv, bool normal) {
  out->push_back(' ');
  out->append(std::to_string(base.v + i + 1));
  if (!uv && !normal) return;
  out->push_back('/');
  if (uv) out->append(std::to_string(base.vt + i + 1));
  if (normal) out->append("/" + std::to_string(base.vn + i + 1));
}

// One tile's group: its vertices, texture coordinates (OBJ's v grows
// upwards, glTF's downwards), normals and faces.
void obj_tile(std::string* out, const std::string& material,
              const engine::GlbMesh& level, ObjCounts* counts) {
  const engine::TexturedMesh& mesh = level.mesh;
  const bool colours = level.image.empty() && !mesh.colors.empty();
  *out += "g " + material + "\nusemtl " + material + "\n";
  for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
    const Eigen::Vector3f& p = mesh.positions[i];
    out->append("v");
    for (int a = 0; a < 3; ++a) obj_number(out, p[a]);
    if (colours)
      for (std::uint8_t c : mesh.colors[i]) obj_number(out, c / 255.0f);
    out->push_back('\n');
  }
  for (const Eigen::Vector2f& t : mesh.uvs)
    obj_line(out, "vt", {t.x(), 1.0f - t.y()});
  for (const Eigen::Vector3f& n : mesh.normals)
    obj_line(out, "vn", {n.x(), n.y(), n.z()});
  const bool uv = !mesh.uvs.empty(), normal = !mesh.normals.empty();
  for (std::size_t f = 0; f < mesh.indices.size(); f += 3) {
    out->push_back('f');
    for (int k = 0; k < 3; ++k)
      obj_face_corner(out, mesh.indices[f + k], *counts, uv, normal);
    out->push_back('\n');
  }
  counts->v += mesh.positions.size();
  counts->vt += mesh.uvs.size();
  counts->vn += mesh.normals.size();
}

// The tile's material: white, lit by nothing but its atlas (the photos
// hold the light).
std::string obj_material(const std::string& material,
                         const std::string& image) {
  std::string mtl =
      "newmtl " + material + "\nKa 1 1 1\nKd 1 1 1\nKs 0 0 0\nd 1\nillum 1\n";
  if (!image.empty()) mtl += "map_Kd " + image + "\n";
  return mtl + "\n";
}

std::string write_obj(const ExportRequest& request, std::ostream& out) {
  const SiteModel model = load_site_model(request.store, request.site);
  const std::vector<engine::MeshTileEntry> tiles = nonempty_mesh_tiles(model);
  const std::string folder = request.site + "/";
  const std::int64_t mtime = model.updated_us / 1000000;
  std::string obj_text = "# arscout: site " + model.site + ", model v" +
                         std::to_string(model.version) +
                         ", the finest mesh level of each tile, in the site "
                         "frame (metres, z up)\nmtllib model.mtl\n";
  std::string mtl_text = "# arscout: one material per mesh tile\n";
  ObjCounts counts;
  ZipWriter zip;
  for (const engine::MeshTileEntry& tile : tiles) {
    const engine::GlbMesh level =
        load_mesh_level(request.store, model, tile, 0);
    const std::string material = "tile_" + tile.tile;
    std::string image;
    if (!level.image.empty()) {
      image = image_file_name(material, level.image_mime);
      zip.add(folder + image, level.image, mtime);
    }
    mtl_text += obj_material(material, image);
    obj_tile(&obj_text, material, level, &counts);
  }
  zip.add(folder + "model.obj", obj_text, mtime);
  zip.add(folder + "model.mtl", mtl_text, mtime);
  put(out, zip.finish());
  return versioned_name(model, "mesh", obj.extension);
}

}  // namespace

const Exporter obj{"obj",
                   ".obj.zip",
                   "application/zip",
                   "the textured mesh (finest level) as Wavefront OBJ with "
                   "its materials and atlases, in a zip",
                   false,
                   false,
                   &write_obj};

}  // namespace arscout::viewer::formats
