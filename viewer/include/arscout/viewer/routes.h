// The viewer's endpoints, added to the API server (ingest::ServerOptions):
//
//   GET /v1/captures/{id}/overlay.jpg   the AR overlay (overlay.h);
//       ?max_side=64..4096, ?cloud=dense|sparse
//   GET /v1/captures/{id}/thumbnail.jpg the photo, small; ?size=16..1024
//   GET /v1/sites/{id}/captures         {"captures": [the site's capture
//       documents]}
//   GET /v1/sites/{id}/export?format=ply|colmap|geocsv|ecef-ply
//       (exports.h); ?cloud=dense|sparse for the cloud formats,
//       ?crs= and ?heights= for las
//   GET /v1/sites/{id}/cameras.geojson  the registered cameras on a map
//   GET /v1/sites/{id}/octree           the web viewer's level-of-detail
//       octree of the current cloud (?cloud=dense|sparse), built once per
//       model version; its nodes at
//   GET /v1/sites/{id}/octree/{version}/{node}.bin
//   GET /v1/sites/{id}/coordinates?x=&y=&z=&crs=&heights=
//       a point of the site's ENU frame in an output CRS (docs/frames.md)
//   GET /v1/sites/{id}/mesh             the textured mesh's tiles and
//       their levels of detail, for streaming; each level's GLB at
//   GET /v1/sites/{id}/mesh/{tile}/{level}  (mesh_routes.h)
//
// and the web viewer's static files (viewer/web, with three.js from its
// node_modules at /vendor/three/).
#pragma once

#include <string>
#include <vector>

#include "arscout/db/store.h"
#include "arscout/ingest/server.h"

namespace arscout::viewer {

std::vector<ingest::ApiRoute> viewer_routes(db::Store& store);

// `/` -> web_root, `/vendor/three/` -> web_root/node_modules/three/.
std::vector<http::StaticMount> web_mounts(const std::string& web_root);

// The web viewer's folder in the source tree this binary was built from.
std::string default_web_root();

}  // namespace arscout::viewer
