// The viewer's endpoints, added to the API server (ingest::ServerOptions):
//
//   GET /v1/captures/{id}/overlay.jpg   the AR overlay (overlay.h);
//       ?max_side=64..4096, ?cloud=dense|sparse
//   GET /v1/captures/{id}/thumbnail.jpg the photo, small; ?size=16..1024
//   GET /v1/sites/{id}/captures         {"captures": [the site's capture
//       documents]}
//   GET /v1/sites/{id}/export?format=ply|colmap|geocsv|ecef-ply
//       (exports.h); ?cloud=dense|sparse for the two PLY formats
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
std::vector<ingest::StaticMount> web_mounts(const std::string& web_root);

// The web viewer's folder in the source tree this binary was built from.
std::string default_web_root();

}  // namespace arscout::viewer
