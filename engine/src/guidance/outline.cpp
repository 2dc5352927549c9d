#include "guidance/outline.h"

#include <algorithm>
#include <cmath>
#include <queue>

namespace arscout::engine::guidance {
namespace {

// Cells this many cells apart (either way) are one structure: a facade
// with a blank stretch of one cell is still one facade.
constexpr int kJoinCells = 2;
constexpr double kUnseenShare = 1.0 / 3;

double cross(const Vec2& o, const Vec2& a, const Vec2& b) {
  return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
}

// Labels every facade cell with its structure (-1 elsewhere).
std::vector<int> label_structures(const GroundGrid& g, int* count) {
  std::vector<int> label(g.cells.size(), -1);
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
      for (int dr = -kJoinCells; dr <= kJoinCells; ++dr)
        for (int dc = -kJoinCells; dc <= kJoinCells; ++dc) {
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

// The share of the segment a-b (its middle 80 %, sampled every half cell)
// that is known: facade on or beside it, or crossed by sight lines.
double known_share(const GroundGrid& g, const Vec2& a, const Vec2& b,
                   int* samples) {
  const double length = distance(a, b);
  const int n = std::max(2, static_cast<int>(length / (g.grid.cell / 2)));
  int known = 0;
  for (int k = 0; k < n; ++k) {
    const double t = 0.1 + 0.8 * (k + 0.5) / n;
    const int i = g.grid.index({a[0] + t * (b[0] - a[0]),
                                a[1] + t * (b[1] - a[1])});
    known += i >= 0 && (g.facade_near(i) || g.cells[i].seen_empty);
  }
  *samples = n;
  return static_cast<double>(known) / n;
}

// One structure's unseen edges from its hull (counter-clockwise: the
// outside is on each edge's right).
std::vector<OutlineGap> gaps_of(const GroundGrid& g,
                                const std::vector<Vec2>& hull,
                                double min_length) {
  std::vector<OutlineGap> gaps;
  double known_total = 0;
  int samples_total = 0;
  for (std::size_t k = 0; k < hull.size(); ++k) {
    const Vec2& a = hull[k];
    const Vec2& b = hull[(k + 1) % hull.size()];
    int samples = 0;
    const double share = known_share(g, a, b, &samples);
    known_total += share * samples;
    samples_total += samples;
    const double length = distance(a, b);
    if (share >= kUnseenShare || length < min_length) continue;
    const Vec2 outward{(b[1] - a[1]) / length, -(b[0] - a[0]) / length};
    gaps.push_back({{a, b, length, bearing_of(outward)}, 0});
  }
  for (OutlineGap& gap : gaps)
    gap.outline_known = samples_total ? known_total / samples_total : 0;
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
