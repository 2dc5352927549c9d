#include "export_support.h"

#include <stdexcept>

#include "arscout/util/error.h"

namespace arscout::viewer::formats {

std::string versioned_name(const SiteModel& model, std::string_view what,
                           std::string_view extension) {
  return model.site + "-v" + std::to_string(model.version) + "-" +
         std::string(what) + std::string(extension);
}

std::string cloud_file_name(const SiteModel& model, Cloud cloud,
                            const Exporter& format, std::string_view suffix) {
  return versioned_name(model, cloud_name(model, cloud) + std::string(suffix),
                        format.extension);
}

engine::Geodetic geographic_origin(const SiteModel& model) {
  const auto& origin = model.document.enu_origin;
  if (!model.document.geo_registered || !origin)
    throw util::Error(util::ErrorKind::kInvalidArgument,
                      "site " + model.site +
                          ": the model is not geo-registered yet (fewer than "
                          "three registered captures with GPS), so it has no "
                          "geographic frame to export");
  return {origin->lat, origin->lon, origin->alt};
}

std::vector<engine::ColoredPoint> nonempty_cloud(db::Store& store,
                                                 const SiteModel& model,
                                                 Cloud cloud) {
  std::vector<engine::ColoredPoint> points = load_cloud(store, model, cloud);
  if (points.empty())
    throw util::Error(util::ErrorKind::kNotFound,
                      "site " + model.site + ": the model has no point cloud");
  return points;
}

std::vector<engine::MeshTileEntry> nonempty_mesh_tiles(const SiteModel& model) {
  db::Document document;
  document.attrs = model.attrs;
  std::vector<engine::MeshTileEntry> tiles;
  // A tile whose points made no surface is listed without levels.
  for (engine::MeshTileEntry& tile : engine::mesh_tiles_of(document))
    if (!tile.levels.empty()) tiles.push_back(std::move(tile));
  if (tiles.empty())
    throw util::Error(util::ErrorKind::kNotFound,
                      "site " + model.site + " has no mesh yet");
  return tiles;
}

engine::GlbMesh load_mesh_level(db::Store& store, const SiteModel& model,
                                const engine::MeshTileEntry& tile,
                                std::size_t level) {
  const std::string bytes = store.get_blob(tile.levels.at(level).blob);
  try {
    return engine::decode_glb_mesh(bytes);
  } catch (const std::runtime_error& e) {
    throw util::Error(util::ErrorKind::kInternal,
                      "site " + model.site + ": mesh tile " + tile.tile +
                          " level " + std::to_string(level) + ": " + e.what());
  }
}

std::string image_file_name(const std::string& name, const std::string& mime) {
  return name + (mime == "image/png" ? ".png" : ".jpg");
}

void put(std::ostream& out, const std::string& bytes) {
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

}  // namespace arscout::viewer::formats
