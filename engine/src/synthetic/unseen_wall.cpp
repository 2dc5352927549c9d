// The block scene's wall that a coverage test leaves unphotographed
// (synthetic_site.h, unseen_inner_wall).
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "arscout/engine/synthetic_site.h"

namespace arscout::engine::synthetic {
namespace {

constexpr double kPi = 3.14159265358979323846;
// A view looks at a wall when the wall is what a tenth of its rays meet
// first: the photos a scout takes of that facade, not those that catch an
// end of it at a grazing angle down another street.
constexpr double kLookingShare = 0.0;

bool is_wall(const Quad& quad) {
  return std::abs(quad.edge_v.z()) > 0 && quad.edge_u.z() == 0;
}

// The compass bearing of the wall's horizontal normal, turned toward the
// mean centre of the views that see it.
double facing_of(const Quad& wall, const BlockScene& scene,
                 const std::vector<bool>& seen_by) {
  Eigen::Vector3d normal(wall.edge_u.y(), -wall.edge_u.x(), 0);
  Eigen::Vector3d toward = Eigen::Vector3d::Zero();
  const Eigen::Vector3d middle = wall.corner + wall.edge_u / 2;
  for (std::size_t i = 0; i < scene.views.size(); ++i)
    if (seen_by[i]) toward += scene.views[i].centre() - middle;
  if (normal.dot(toward) < 0) normal = -normal;
  const double deg = std::atan2(normal.x(), normal.y()) * 180 / kPi;
  return deg < 0 ? deg + 360 : deg;
}

// The shortest stretch of the closed walk (views in walking order, the last
// beside the first) that holds every view in `looking`: what a scout who
// skipped that facade left out.
std::vector<bool> stretch_of(const std::vector<bool>& looking) {
  const int n = static_cast<int>(looking.size());
  std::vector<int> at;
  for (int i = 0; i < n; ++i)
    if (looking[i]) at.push_back(i);
  std::vector<bool> stretch(looking.size(), false);
  if (at.empty()) return stretch;
  // The longest run of views between two looking ones is what is kept.
  int widest = -1, after = 0;
  for (std::size_t k = 0; k < at.size(); ++k) {
    const int next = k + 1 < at.size() ? at[k + 1] : at[0] + n;
    if (next - at[k] > widest) {
      widest = next - at[k];
      after = static_cast<int>((k + 1) % at.size());
    }
  }
  for (int i = at[after], left = n - widest + 1; left > 0; --left, ++i)
    stretch[i % n] = true;
  return stretch;
}

// A wall of the building the walk goes round: the route's centre (the
// world origin) is behind it (its edge_u x edge_v points out) and in front
// of its width.
bool faces_away_from_origin(const Quad& wall) {
  const Eigen::Vector3d out = wall.edge_u.cross(wall.edge_v);
  const double along =
      -wall.corner.dot(wall.edge_u) / wall.edge_u.squaredNorm();
  return out.dot(-wall.corner) < 0 && along > 0 && along < 1;
}

}  // namespace

UnseenWall unseen_inner_wall(const BlockScene& scene, double min_width_m) {
  const std::size_t quads = scene.site.quads.size();
  std::vector<std::vector<bool>> looking(quads,
                                         std::vector<bool>(scene.views.size()));
  for (std::size_t v = 0; v < scene.views.size(); ++v) {
    const std::vector<int> rays = quads_seen(scene.site, scene.views[v]);
    long all = 0;
    for (int r : rays) all += r;
    for (std::size_t q = 0; q < quads; ++q)
      looking[q][v] = rays[q] > kLookingShare * all;
  }
  UnseenWall best;
  long fewest = static_cast<long>(scene.views.size()) + 1;
  for (std::size_t q = 0; q < quads; ++q) {
    const Quad& quad = scene.site.quads[q];
    if (!is_wall(quad) || quad.edge_u.norm() < min_width_m ||
        !faces_away_from_origin(quad))
      continue;
    const std::vector<bool> stretch = stretch_of(looking[q]);
    const long dropped = std::count(stretch.begin(), stretch.end(), true);
    if (std::count(looking[q].begin(), looking[q].end(), true) < 3 ||
        dropped >= fewest)
      continue;
    fewest = dropped;
    best.quad = static_cast<int>(q);
    best.seen_by = stretch;
    best.from = quad.corner;
    best.to = quad.corner + quad.edge_u;
    best.facing_deg = facing_of(quad, scene, looking[q]);
  }
  if (best.quad < 0)
    throw std::invalid_argument(
        "the walk goes round no single building with a wall of " +
        std::to_string(min_width_m) + " m or more (use 60-80 views)");
  return best;
}

}  // namespace arscout::engine::synthetic
