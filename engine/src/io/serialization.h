// The Scene as bytes: a versioned little-endian binary layout, exact to the
// bit for every number, so a restored scene continues exactly as the
// original would have.
#pragma once

#include <functional>
#include <string>

#include "scene/scene.h"

namespace arscout::engine {

// The bytes of an image's features by its id; throws when it has none.
using FeatureSource = std::function<std::string(const std::string& id)>;

// With `features_apart`, the images' keypoints, descriptors, colours and
// patches
// (fixed once extracted, most of the bytes) are left out and
// serialize_features() gives them per image, for a caller that stores each
// once; images without keypoints keep theirs inline either way.
std::string serialize_scene(const Scene& scene, bool features_apart = false);
// Throws std::runtime_error for bytes that are not a scene of version 1 to
// 3, or when features kept apart are missing or do not fit (`features` is
// asked only for those).
Scene deserialize_scene(const std::string& bytes,
                        const FeatureSource& features = {});

// One image's features: its id, keypoints, descriptors, colours and
// patches, deflated, with extracted descriptors at two bytes per component
// (ARSFEAT3: about half the floats' size). Features written before
// (floats, ARSFEAT2; before patches were kept, ARSFEAT1) still read.
std::string serialize_features(const SceneImage& image);

}  // namespace arscout::engine
