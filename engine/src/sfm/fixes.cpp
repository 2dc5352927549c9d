// Cameras against their fixes (sfm/fixes.h).
#include "sfm/fixes.h"

#include <algorithm>
#include <cmath>

namespace arscout::engine {

double FixedCentres::fit_threshold() const {
  return std::max(3 * accuracy, 5.0);
}

FixedCentres fixed_centres(const Scene& scene, int component) {
  FixedCentres result;
  for (const SceneImage& image : scene.images) {
    if (!image.registered || !image.gps || image.component != component)
      continue;
    result.centres.push_back(image.centre());
    result.fixes.push_back(image.gps_enu);
    result.accuracy +=
        std::hypot(image.gps->h_acc * std::sqrt(2.0), image.gps->v_acc);
  }
  if (!result.centres.empty()) result.accuracy /= result.centres.size();
  return result;
}

std::optional<Similarity> robust_placement(const FixedCentres& fixed,
                                           uint64_t seed,
                                           std::vector<int>* inliers) {
  if (fixed.centres.size() < 3) return std::nullopt;
  return estimate_similarity(fixed.centres, fixed.fixes, fixed.fit_threshold(),
                             seed, inliers);
}

namespace {

// How far a least-squares fit of 7 parameters to n fixes is off at the
// fixed cameras, in deviations of one fix: sqrt(7 / n), at most one.
double fit_error_share(size_t n) {
  return std::sqrt(std::min(1.0, 7.0 / static_cast<double>(n)));
}

}  // namespace

// Repeated texture (one facade on two buildings, a row of identical
// windows) can give a similarity that dozens of common points agree on and
// that is still false. Each side's fixes place it on their own (robustly:
// a side's current frame may itself be far from its fixes); a true merge
// puts gone's cameras where its own placement puts them, to within what
// the two placements can tell (three times their expected error at the
// cameras).
bool merge_agrees_with_fixes(const Scene& scene, int keep, int gone,
                             const Similarity& sim) {
  const FixedCentres kept = fixed_centres(scene, keep);
  const FixedCentres moved = fixed_centres(scene, gone);
  const auto keep_place = robust_placement(kept, scene.images.size(), nullptr);
  const auto gone_place = robust_placement(moved, scene.images.size(), nullptr);
  if (!keep_place || !gone_place) return true;
  double squared = 0;
  for (const Eigen::Vector3d& centre : moved.centres) {
    squared +=
        (keep_place->apply(sim.apply(centre)) - gone_place->apply(centre))
            .squaredNorm();
  }
  const double rms = std::sqrt(squared / moved.centres.size());
  const double accuracy = std::max(kept.accuracy, moved.accuracy);
  const double allowed = 3 * accuracy *
                         (fit_error_share(kept.centres.size()) +
                          fit_error_share(moved.centres.size()));
  return rms <= allowed;
}

}  // namespace arscout::engine
