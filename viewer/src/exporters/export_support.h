// What the exporters share: a file name from the model version, the
// geographic frame a geographic format needs, errors in util::Error's
// words.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "arscout/engine/geo.h"
#include "arscout/engine/mesh.h"
#include "arscout/engine/service.h"
#include "arscout/viewer/exporter.h"
#include "arscout/viewer/site_model.h"

namespace arscout::viewer::formats {

// SITE-vVERSION-WHAT.EXTENSION ("s1-v7-dense.ply").
std::string versioned_name(const SiteModel& model, std::string_view what,
                           std::string_view extension);
// The name of a cloud format's file: the cloud's kind as WHAT, `suffix`
// after it ("-ecef").
std::string cloud_file_name(const SiteModel& model, Cloud cloud,
                            const Exporter& format,
                            std::string_view suffix = "");

// The model's ENU origin on WGS84. Throws util::Error kInvalidArgument when
// the model is not geo-registered: its frame is arbitrary, so there is no
// honest geography to give.
engine::Geodetic geographic_origin(const SiteModel& model);

// The cloud of the kind asked for; util::Error kNotFound when it is empty.
std::vector<engine::ColoredPoint> nonempty_cloud(db::Store& store,
                                                 const SiteModel& model,
                                                 Cloud cloud);

// The model's textured mesh, its "mesh_tiles" (engine::mesh_tiles_of) that
// have levels (a tile whose points made no surface has none), in tile
// order. Throws util::Error kNotFound ("site S has no mesh yet") when there
// are none.
std::vector<engine::MeshTileEntry> nonempty_mesh_tiles(const SiteModel& model);

// Level `level` of mesh tile `tile` read from its stored GLB, the atlas as
// the image file it embeds. Throws what the store throws (kNotFound for a
// blob collected since a later model replaced it: export again), and
// util::Error kInternal when the blob is not a mesh GLB.
engine::GlbMesh load_mesh_level(db::Store& store, const SiteModel& model,
                                const engine::MeshTileEntry& tile,
                                std::size_t level);

// The file name of an atlas image of `mime` type: "NAME.jpg" or "NAME.png".
std::string image_file_name(const std::string& name, const std::string& mime);

// Writes `bytes` to `out`.
void put(std::ostream& out, const std::string& bytes);

}  // namespace arscout::viewer::formats
