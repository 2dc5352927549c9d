// A site with a textured mesh and no photos, for the mesh exports' tests:
// two textured height-field patches, mesh tiles "0_0" (x 0..10 m) and
// "1_0" (x 10..20 m) over y 0..10 m, meeting edge to edge at x = 10 (the
// same surface, z = 2 + 1.5 sin(x / 2.5) cos(y / 3) + 0.1 x, sampled on
// one 0.25 m grid), each with its own 256 x 256 atlas (a checkerboard of
// 1 m squares in the tile's two colours), per-vertex colours from it and
// unit normals. Their levels of detail come from engine::mesh_levels and
// are stored as engine::encode_glb blobs named in the model document's
// "mesh_tiles", as the engine's mesh phase publishes them.
#pragma once

#include <string>
#include <vector>

#include "arscout/db/store.h"
#include "arscout/engine/geo.h"
#include "arscout/engine/mesh.h"

namespace mesh_site {

// Where the site is geo-registered.
inline const arscout::engine::Geodetic kOrigin{46.5191, 6.5668, 390.0};

struct MeshTile {
  std::string name;                                // "0_0", "1_0"
  std::vector<arscout::engine::MeshLevel> levels;  // finest first
  std::vector<std::string> glbs;                   // each level's stored GLB
};

// The two tiles' finest meshes.
std::vector<arscout::engine::TexturedMesh> synthetic_mesh_tiles();

// Writes /sites/{site} and its model (geo-registered at kOrigin, or not)
// with the two tiles' levels as blobs named in its "mesh_tiles", and a
// third tile, "5_5", listed without levels (its points made no surface);
// returns the two tiles. With `with_mesh` false only "5_5" is listed: the
// model has no mesh.
std::vector<MeshTile> write_mesh_site(arscout::db::Store& store,
                                      const std::string& site,
                                      bool geo_registered = true,
                                      bool with_mesh = true);

}  // namespace mesh_site
