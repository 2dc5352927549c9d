// Structures' outlines on the ground grid (coverage_grid.h), and the
// outline edges nobody has looked at: the unseen facades of coverage.h.
#pragma once

#include <vector>

#include "guidance/coverage_grid.h"

namespace arscout::engine::guidance {

// One unseen outline edge, with how well the rest of its structure's
// outline is known (0..1): a building seen on three sides is a better
// guess of where its fourth facade stands than a fragment.
struct OutlineGap {
  UnseenFacade facade;
  double outline_known = 0;
};

// The facade cells grouped into structures (cells at most one empty cell
// apart are one structure); each structure's outline is the convex hull of
// its facade points. An outline edge of at least `min_length` metres is
// unseen when less than a third of it lies on or beside facade cells or on
// cells that sight lines crossed. Largest first.
std::vector<OutlineGap> unseen_outline_edges(const GroundGrid& g,
                                             double min_length);

// The convex hull of `points`, counter-clockwise, without collinear
// points (Andrew's monotone chain). Fewer than 3 distinct points: those.
std::vector<Vec2> convex_hull(std::vector<Vec2> points);

}  // namespace arscout::engine::guidance
