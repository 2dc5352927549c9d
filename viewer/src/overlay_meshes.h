// Which of a site's mesh tiles a camera sees, and at which level of detail
// (the mesh overlay's; docs/mesh.md, "The scout's overlay").
#pragma once

#include <vector>

#include "arscout/db/store.h"
#include "arscout/engine/mesh.h"
#include "arscout/viewer/site_model.h"

namespace arscout::viewer {

// The finest level's surface may be drawn this many output pixels away
// from where a coarser level puts it before the finer one is used.
constexpr double kOverlayMaxPixelError = 1.0;

// The mesh tiles of `model` whose boxes lie (partly) in front of `camera`
// and inside its view, each at the coarsest level whose geometric error,
// seen from the camera at the box's nearest point, is at most
// kOverlayMaxPixelError pixels for the focal length `focal_px` (output
// pixels), its atlas decoded. Throws util::Error kNotFound when the model
// has no mesh, and what formats::load_mesh_level throws for a blob gone or
// damaged.
std::vector<engine::TexturedMesh> meshes_seen_by(db::Store& store,
                                                 const SiteModel& model,
                                                 const ImageCamera& camera,
                                                 double focal_px);

}  // namespace arscout::viewer
