// A 3D Tiles 1.1 tileset of a site's textured mesh (docs/mesh.md,
// "Exports"): per mesh tile a chain of its levels of detail with
// replacement refinement (the coarsest level at the top, each finer level
// its child, the finest a leaf), glTF (GLB) contents turned y up as the
// specification has it, boxes and the root in the site's ENU frame, and a
// root transform from ENU to ECEF (WGS84). Built one mesh tile at a time,
// so that a site's levels are never all decoded at once.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "arscout/engine/geo.h"
#include "arscout/engine/mesh.h"
#include "point_tileset.h"

namespace arscout::viewer {

// An axis-aligned box in the site frame.
struct MeshBox {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300);
  Eigen::Vector3d hi = Eigen::Vector3d::Constant(-1e300);
  bool empty() const { return (lo.array() > hi.array()).any(); }
  void add(const MeshBox& other);
  Eigen::Vector3d centre() const { return (lo + hi) / 2; }
};

// The box of a mesh's positions.
MeshBox mesh_box(const engine::TexturedMesh& mesh);

class MeshTilesetBuilder {
 public:
  explicit MeshTilesetBuilder(const engine::Geodetic& origin)
      : origin_(origin) {}

  // One mesh tile, `name` its dense tile's ("ix_iy"): `levels` finest
  // first with their geometric errors (site units; `errors` as many as
  // levels). Returns its contents, tiles/NAME-lLEVEL.glb, each positioned
  // relative to the tile box's centre (the node's translation). A level's
  // tile has the largest error of it and the finer levels (the chain's
  // errors never grow downwards), the finest 0. Every level of a tile has
  // the box of all of them (a coarser level's vertices are the finer's).
  // Throws std::invalid_argument for no levels, a count of errors that
  // does not match, or a level encode_glb_meshes refuses.
  std::vector<TilesetFile> add_tile(const std::string& name,
                                    const std::vector<engine::GlbMesh>& levels,
                                    const std::vector<double>& errors);

  // tileset.json over the tiles added: a root without content above the
  // chains (replacement refinement, the ENU-to-ECEF transform), whose
  // geometric error, and the tileset's, is the largest of the chains' and
  // never below the diagonal of the site's box: the root alone shows
  // nothing, so a client must always refine it. Throws
  // std::invalid_argument when no tile was added.
  TilesetFile finish() const;

 private:
  engine::Geodetic origin_;
  std::vector<nlohmann::json> chains_;
  MeshBox box_;
  double largest_error_ = 0;
};

}  // namespace arscout::viewer
