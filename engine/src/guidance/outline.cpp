#include "guidance/outline.h"

#include <algorithm>
#include <cmath>
#include <queue>

namespace arscout::engine::guidance {
namespace {

// Facade cells within this many metres (either way) are one structure: a
// facade with a blank stretch (no corners to match) is still one facade,
// while the two sides of a street are not.
constexpr double kJoinMetres = 2.5;
constexpr double kUnseenShare = 1.0 / 3;
// Outline edges are examined in bins of this length; a facade point this
// close to an edge lies on it.
constexpr double kBinMetres = 0.5;
constexpr double kOnEdgeMetres = 0.5;

double cross(const Vec2& o, const Vec2& a, const Vec2& b) {
  return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
}

// Labels every facade cell with its structure (-1 elsewhere).
std::vector<int> label_structures(const GroundGrid& g, int* count) {
  std::vector<int> label(g.cells.size(), -1);
  const int join = std::max(1, static_cast<int>(kJoinMetres / g.grid.cell));
  *count = 0;
  for (int seed = 0; seed < g.grid.size(); ++seed) {
    if (!g.facade_cell(seed) || label[seed] >= 0) continue;
    std::queue<int> open;
    open.push(seed);
    label[seed] = *count;
    while (!open.empty()) {
      const int i = open.front();
      open.pop();
      const int c = i % g.grid.columns, r = i / g.grid.columns;
      for (int dr = -join; dr <= join; ++dr)
        for (int dc = -join; dc <= join; ++dc) {
          const int cc = c + dc, rr = r + dr;
          if (cc < 0 || rr < 0 || cc >= g.grid.columns || rr >= g.grid.rows)
            continue;
          const int j = rr * g.grid.columns + cc;
          if (!g.facade_cell(j) || label[j] >= 0) continue;
          label[j] = *count;
          open.push(j);
        }
    }
    ++*count;
  }
  return label;
}

// The share of the segment a-b (its middle 80 %, in half-metre bins) that
// facade points lie on (within half a metre of it).
double facade_share(const GroundGrid& g, const Vec2& a, const Vec2& b) {
  const Vec2 e{b[0] - a[0], b[1] - a[1]};
  const double length = distance(a, b);
  const int bins = std::max(1, static_cast<int>(0.8 * length / kBinMetres));
  std::vector<bool> on(bins, false);
  for (const Sighted& p : g.points) {
    if (!p.facade) continue;
    const Vec2 d{p.xy[0] - a[0], p.xy[1] - a[1]};
    const double t = (d[0] * e[0] + d[1] * e[1]) / (length * length);
    const double off = std::abs(d[0] * e[1] - d[1] * e[0]) / length;
    if (t < 0.1 || t >= 0.9 || off > kOnEdgeMetres) continue;
    on[std::min(bins - 1, static_cast<int>((t - 0.1) / 0.8 * bins))] = true;
  }
  return static_cast<double>(std::count(on.begin(), on.end(), true)) / bins;
}

// The share of the segment a-b (its middle 80 %, in half-metre bins) that
// sight lines cross a metre or more short of what they see: open space
// there, not a wall. (A sight line that runs beside the edge, down the
// street in front of a wall, crosses nothing.)
double crossed_share(const GroundGrid& g, const Vec2& a, const Vec2& b) {
  const Vec2 e{b[0] - a[0], b[1] - a[1]};
  const int bins =
      std::max(1, static_cast<int>(0.8 * distance(a, b) / kBinMetres));
  std::vector<bool> crossed(bins, false);
  for (const auto& [image, point] : g.sight_lines) {
    const Vec2& c = g.cameras[image];
    const Vec2& p = g.points[point].xy;
    const Vec2 r{p[0] - c[0], p[1] - c[1]};
    const double denominator = r[0] * e[1] - r[1] * e[0];
    const double range = std::hypot(r[0], r[1]);
    if (std::abs(denominator) < 1e-12 || range <= 1) continue;
    const Vec2 d{a[0] - c[0], a[1] - c[1]};
    const double s = (d[0] * e[1] - d[1] * e[0]) / denominator;  // on r
    const double t = (d[0] * r[1] - d[1] * r[0]) / denominator;  // on e
    if (s < 0 || s > 1 - 1 / range || t < 0.1 || t >= 0.9) continue;
    crossed[std::min(bins - 1, static_cast<int>((t - 0.1) / 0.8 * bins))] =
        true;
  }
  return static_cast<double>(std::count(crossed.begin(), crossed.end(), true)) /
         bins;
}

// One structure's unseen edges from its hull (counter-clockwise: the
// outside is on each edge's right).
std::vector<OutlineGap> gaps_of(const GroundGrid& g,
                                const std::vector<Vec2>& hull,
                                double min_length) {
  std::vector<OutlineGap> gaps;
  double known_total = 0, length_total = 0;
  for (std::size_t k = 0; k < hull.size(); ++k) {
    const Vec2& a = hull[k];
    const Vec2& b = hull[(k + 1) % hull.size()];
    const double share = facade_share(g, a, b);
    const double length = distance(a, b);
    known_total += share * length;
    length_total += length;
    if (share >= kUnseenShare || length < min_length ||
        crossed_share(g, a, b) >= kUnseenShare)
      continue;
    const Vec2 outward{(b[1] - a[1]) / length, -(b[0] - a[0]) / length};
    gaps.push_back({{a, b, length, bearing_of(outward)}, 0});
  }
  for (OutlineGap& gap : gaps)
    gap.outline_known = length_total > 0 ? known_total / length_total : 0;
  return gaps;
}

}  // namespace

std::vector<Vec2> convex_hull(std::vector<Vec2> points) {
  std::sort(points.begin(), points.end());
  points.erase(std::unique(points.begin(), points.end()), points.end());
  if (points.size() < 3) return points;
  std::vector<Vec2> hull(2 * points.size());
  std::size_t k = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {  // lower chain
    while (k >= 2 && cross(hull[k - 2], hull[k - 1], points[i]) <= 0) --k;
    hull[k++] = points[i];
  }
  for (std::size_t i = points.size() - 1, lower = k + 1; i-- > 0;) {
    while (k >= lower && cross(hull[k - 2], hull[k - 1], points[i]) <= 0) --k;
    hull[k++] = points[i];
  }
  hull.resize(k - 1);
  return hull;
}

std::vector<OutlineGap> unseen_outline_edges(const GroundGrid& g,
                                             double min_length) {
  int count = 0;
  const std::vector<int> label = label_structures(g, &count);
  std::vector<std::vector<Vec2>> members(count);
  for (const Sighted& p : g.points) {
    const int i = g.grid.index(p.xy);
    if (p.facade && i >= 0 && label[i] >= 0) members[label[i]].push_back(p.xy);
  }
  std::vector<OutlineGap> gaps;
  for (const std::vector<Vec2>& structure : members) {
    const std::vector<Vec2> hull = convex_hull(structure);
    if (hull.size() < 3) continue;
    for (OutlineGap& gap : gaps_of(g, hull, min_length))
      gaps.push_back(std::move(gap));
  }
  std::sort(gaps.begin(), gaps.end(),
            [](const OutlineGap& a, const OutlineGap& b) {
              return a.facade.length_m > b.facade.length_m;
            });
  return gaps;
}

}  // namespace arscout::engine::guidance
