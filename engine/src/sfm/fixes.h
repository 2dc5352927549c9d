// A component's cameras against their GPS fixes: what the fixes can tell
// about a placement in the site's ENU frame, and about a merge of two
// components, independently of the images.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "estimators/estimators.h"
#include "scene/scene.h"

namespace arscout::engine {

// The registered cameras of one component that have a fix: their centres
// (in the component's frame), their fixes (ENU), and the fixes' mean 3D
// accuracy in metres (the horizontal deviation on both axes and the
// vertical one).
struct FixedCentres {
  std::vector<Eigen::Vector3d> centres, fixes;
  double accuracy = 0;

  // The inlier distance of a robust fit of the centres to the fixes:
  // three deviations, never under 5 m (a receiver's own estimate of its
  // accuracy is often optimistic).
  double fit_threshold() const;
};

FixedCentres fixed_centres(const Scene& scene, int component);

// The robust similarity from the centres to their fixes (RANSAC within
// fit_threshold, seeded by `seed`), and its inliers where `inliers` is
// not null; none below 3 fixes.
std::optional<Similarity> robust_placement(const FixedCentres& fixed,
                                           uint64_t seed,
                                           std::vector<int>* inliers);

// Whether moving component `gone` by `sim` into `keep`'s frame puts its
// cameras where its own fixes place them: each side is placed by its fixes
// (a robust similarity), and gone's cameras taken through the merge and
// keep's placement must lie within three times the two placements'
// expected error (the fixes' accuracy times sqrt(7 / n) for n fixes, at
// most once) of where gone's placement puts them, as a root mean square.
// True when either side has fewer than 3 fixes: they cannot tell then.
// Deterministic (the RANSAC is seeded).
bool merge_agrees_with_fixes(const Scene& scene, int keep, int gone,
                             const Similarity& sim);

}  // namespace arscout::engine
