// The textured mesh for the web viewer, streamed by level of detail
// (docs/api.md, docs/viewer.md):
//
//   GET /v1/sites/{id}/mesh                 the model's mesh tiles: each
//       tile's box and its levels (url, blob, triangles, geometric error,
//       bytes), finest first, with the model version
//   GET /v1/sites/{id}/mesh/{tile}/{level}  a level's GLB as the engine
//       stored it (site frame, z up); ?blob=HASH, as the listing's urls
//       carry, makes the answer immutable (410 once the tile has changed)
//
// Both answer 404 with the reason for an unknown site, a site without a
// mesh yet, an unknown tile or a level out of range, and 304 to a request
// whose If-None-Match names the current ETag.
#pragma once

#include <cstdint>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "arscout/db/store.h"
#include "arscout/ingest/server.h"
#include "mesh_tileset.h"

namespace arscout::viewer {

// A stored mesh GLB's box (its positions' bounds in the site frame) and
// size in bytes.
struct GlbBounds {
  MeshBox box;
  std::int64_t bytes = 0;
};

// The glTF JSON of a GLB (its first chunk), from its first bytes; `need`
// receives how many bytes the chunk needs when `head` is too short
// (std::nullopt then). Throws std::runtime_error when `head` is not a GLB.
std::optional<std::string> glb_json_chunk(const std::string& head,
                                          std::size_t* need);

// The box of a glTF's POSITION accessors (their min and max, moved by the
// translation of the node that draws the mesh). Throws std::runtime_error
// when a POSITION accessor has no min and max or there is none.
MeshBox gltf_position_box(const std::string& json);

// GlbBounds of stored GLBs, read from their glTF JSON alone (the binary
// chunk is not read) and kept per blob hash: a blob never changes.
// Thread-safe.
class MeshBoxCache {
 public:
  // std::nullopt when the blob is not stored (collected after a later
  // model replaced its tile). Throws util::Error kInternal when it is not a
  // GLB with position bounds.
  std::optional<GlbBounds> get(db::Store& store, const std::string& hash);
  std::size_t size() const;

 private:
  static constexpr std::size_t kMaxEntries = 65536;
  mutable std::mutex mutex_;
  std::map<std::string, GlbBounds> entries_;
};

// The two routes above, sharing one MeshBoxCache.
std::vector<ingest::ApiRoute> mesh_routes(db::Store& store);

}  // namespace arscout::viewer
