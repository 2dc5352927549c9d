#include "arscout/engine/coverage.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <queue>
#include <stdexcept>

#include "guidance/coverage_grid.h"
#include "guidance/outline.h"

namespace arscout::engine {
namespace {

using guidance::bearing_of;
using guidance::distance;
using guidance::GroundGrid;
using guidance::unit_of_bearing;
using guidance::Vec2;

// What a suggestion adds, per metre of facade: a side nobody saw counts
// ten times a facade seen from a single direction (a hole against a weak
// spot), and a run of the latter counts for at most kOneDirectionMetres.
// A gap between components outranks both: until it is bridged the site is
// two models.
constexpr double kOneDirectionWeight = 0.1;
constexpr double kOneDirectionMetres = 10;
constexpr double kComponentGapScore = 1000;
// A second direction: the oblique view beside the one the facade has.
constexpr double kObliqueDeg = 40;

Vec2 along(const Vec2& from, double bearing_deg, double metres) {
  const Vec2 u = unit_of_bearing(bearing_deg);
  return {from[0] + metres * u[0], from[1] + metres * u[1]};
}

// From `from` toward `bearing_deg`, the standoff out or, when facade cells
// come first (the other side of a street), a metre short of them.
Vec2 standpoint(const GroundGrid& g, const Vec2& from, double bearing_deg) {
  const double step = g.grid.cell / 2;
  for (double d = 2 * g.grid.cell; d <= g.standoff; d += step)
    if (g.facade_cell(g.grid.index(along(from, bearing_deg, d))))
      return along(from, bearing_deg, std::max(step, d - 1));
  return along(from, bearing_deg, g.standoff);
}

ShotSuggestion unseen_suggestion(const guidance::OutlineGap& gap,
                                 const GroundGrid& g) {
  const UnseenFacade& f = gap.facade;
  const Vec2 middle{(f.from[0] + f.to[0]) / 2, (f.from[1] + f.to[1]) / 2};
  ShotSuggestion s;
  s.position = standpoint(g, middle, f.facing_deg);
  s.heading_deg = std::fmod(f.facing_deg + 180, 360);
  s.kind = "unseen_facade";
  s.reason =
      "the " + compass_name(f.facing_deg) + " side has never been photographed";
  s.score = f.length_m * (0.5 + gap.outline_known);
  return s;
}

// Facade cells seen from one direction only, in runs of neighbouring cells
// that face the same sector.
std::vector<std::vector<const CoverageCell*>> one_direction_runs(
    const std::vector<CoverageCell>& cells) {
  std::vector<const CoverageCell*> open;
  for (const CoverageCell& c : cells)
    if (c.directions == 1) open.push_back(&c);
  std::vector<std::vector<const CoverageCell*>> runs;
  std::vector<bool> taken(open.size(), false);
  for (std::size_t seed = 0; seed < open.size(); ++seed) {
    if (taken[seed]) continue;
    taken[seed] = true;
    std::vector<const CoverageCell*> run{open[seed]};
    for (std::size_t k = 0; k < run.size(); ++k)
      for (std::size_t j = 0; j < open.size(); ++j)
        if (!taken[j] && std::abs(open[j]->column - run[k]->column) <= 1 &&
            std::abs(open[j]->row - run[k]->row) <= 1 &&
            guidance::sector_of(open[j]->facing_deg) ==
                guidance::sector_of(run[k]->facing_deg)) {
          taken[j] = true;
          run.push_back(open[j]);
        }
    if (run.size() >= 2) runs.push_back(std::move(run));
  }
  return runs;
}

// The oblique view of a run, from the side whose standpoint sight lines
// crossed (a street the scout can walk), else the first side.
ShotSuggestion one_direction_suggestion(
    const std::vector<const CoverageCell*>& run, const GroundGrid& g) {
  Vec2 middle{0, 0};
  for (const CoverageCell* c : run) {
    middle[0] += c->centre[0] / run.size();
    middle[1] += c->centre[1] / run.size();
  }
  const double facing = run.front()->facing_deg;
  Vec2 position = standpoint(g, middle, facing + kObliqueDeg);
  const int i = g.grid.index(position);
  if (i < 0 || !g.cells[i].seen_empty)
    position = standpoint(g, middle, facing - kObliqueDeg);
  ShotSuggestion s;
  s.position = position;
  s.heading_deg =
      bearing_of({middle[0] - position[0], middle[1] - position[1]});
  s.kind = "one_direction";
  s.reason = compass_name(facing) + " facade seen from one direction only";
  s.score = kOneDirectionWeight *
            std::min(kOneDirectionMetres, run.size() * g.grid.cell);
  return s;
}

// Halfway across the shortest stretch between the largest component's
// photos and another component's, looking toward the other.
std::vector<ShotSuggestion> component_gap_suggestions(const Model& model) {
  std::vector<ShotSuggestion> out;
  if (model.components.size() < 2) return out;
  const int main_id = model.components.front().id;
  for (std::size_t k = 1; k < model.components.size(); ++k) {
    double best = std::numeric_limits<double>::infinity();
    Vec2 from{}, to{};
    for (const ModelImage& a : model.images) {
      if (a.component != main_id) continue;
      for (const ModelImage& b : model.images) {
        if (b.component != model.components[k].id) continue;
        const double d =
            distance(guidance::centre_xy(a), guidance::centre_xy(b));
        if (d < best) {
          best = d;
          from = guidance::centre_xy(a);
          to = guidance::centre_xy(b);
        }
      }
    }
    if (!std::isfinite(best)) continue;
    ShotSuggestion s;
    s.position = {(from[0] + to[0]) / 2, (from[1] + to[1]) / 2};
    s.heading_deg = bearing_of({to[0] - from[0], to[1] - from[1]});
    s.kind = "component_gap";
    s.reason = "gap between components: photos here join a part of " +
               std::to_string(model.components[k].images) +
               " photos to the main model";
    s.score = kComponentGapScore + model.components[k].images;
    out.push_back(std::move(s));
  }
  return out;
}

// How easily a scout gets to a standpoint: 1 where photos were taken,
// half a standoff from the nearest photo 0.8, two standoffs away 0.2. The
// back of a building across the street is as unseen as the side of one
// the scouts walked past, but only the latter is a few steps away.
double reach(const GroundGrid& g, const Vec2& position) {
  double nearest = std::numeric_limits<double>::infinity();
  for (const Vec2& camera : g.cameras)
    nearest = std::min(nearest, distance(camera, position));
  const double r = nearest / g.standoff;
  return 1 / (1 + r * r);
}

// Weighs each suggestion by its reach (a gap between components keeps its
// rank) and sorts them, best first.
void weigh_by_reach(std::vector<ShotSuggestion>& suggestions,
                    const GroundGrid& g) {
  for (ShotSuggestion& s : suggestions)
    if (s.kind != "component_gap") s.score *= reach(g, s.position);
  std::stable_sort(suggestions.begin(), suggestions.end(),
                   [](const ShotSuggestion& a, const ShotSuggestion& b) {
                     return a.score > b.score;
                   });
}

}  // namespace

std::vector<ShotSuggestion> rank_for(
    const Coverage& coverage, const std::optional<std::array<double, 2>>& near,
    int max) {
  std::vector<ShotSuggestion> ranked = coverage.suggestions;
  if (near) {
    // A suggestion four standoffs away counts half.
    for (ShotSuggestion& s : ranked)
      s.score /= 1 + distance(s.position, *near) / (4 * coverage.standoff_m);
    std::stable_sort(ranked.begin(), ranked.end(),
                     [](const ShotSuggestion& a, const ShotSuggestion& b) {
                       return a.score > b.score;
                     });
  }
  if (ranked.size() > static_cast<std::size_t>(std::max(0, max)))
    ranked.resize(std::max(0, max));
  return ranked;
}

std::string compass_name(double bearing_deg) {
  static const char* const kNames[8] = {
      "north", "north-east", "east", "south-east",
      "south", "south-west", "west", "north-west"};
  return kNames[guidance::sector_of(bearing_deg)];
}

Coverage analyse_coverage(const Model& model, const CoverageOptions& options) {
  if (!model.geo_registered)
    throw std::invalid_argument(
        "coverage needs a geo-registered model (metres, z up)");
  if (!(options.cell_m > 0) || options.max_cells_per_side < 2)
    throw std::invalid_argument("coverage: cell_m > 0 and at least 2 cells");
  Coverage out;
  if (model.images.empty()) return out;
  const GroundGrid g = guidance::build_ground_grid(model, options);
  out.cell_m = g.grid.cell;
  out.grid_origin = g.grid.origin;
  out.columns = g.grid.columns;
  out.rows = g.grid.rows;
  out.ground_z = g.ground_z;
  out.standoff_m = g.standoff;
  for (int i = 0; i < g.grid.size(); ++i)
    if (g.facade_cell(i)) out.cells.push_back(guidance::summarise_cell(g, i));
  for (const guidance::OutlineGap& gap :
       guidance::unseen_outline_edges(g, options.min_unseen_facade_m)) {
    out.unseen.push_back(gap.facade);
    out.suggestions.push_back(unseen_suggestion(gap, g));
  }
  for (const auto& run : one_direction_runs(out.cells))
    out.suggestions.push_back(one_direction_suggestion(run, g));
  for (ShotSuggestion& s : component_gap_suggestions(model))
    out.suggestions.push_back(std::move(s));
  weigh_by_reach(out.suggestions, g);
  out.suggestions = rank_for(out, options.near, options.max_suggestions);
  return out;
}

}  // namespace arscout::engine
