// The Scene as bytes: a versioned little-endian binary layout, exact to the
// bit for every number, so a restored scene continues exactly as the
// original would have.
#pragma once

#include <string>

#include "scene.h"

namespace arscout::engine {

std::string serialize_scene(const Scene& scene);
// Throws std::runtime_error for bytes that are not a scene of this version.
Scene deserialize_scene(const std::string& bytes);

}  // namespace arscout::engine
