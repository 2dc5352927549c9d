// Coverage guidance: where a site's model is thin and where a scout should
// shoot next, read from the model itself (poses and point tracks), not from
// the GPS track alone.
//
// The ground is cut into square cells in the site's ENU frame. A cell holds
// facade when sparse points above the ground fall in it; its points' tracks
// say which registered photos see it and from which directions (8 compass
// sectors of 45 degrees, counted from the cell toward each photo). The
// space between each photo and the points it sees is marked as seen empty.
// From that:
//   - an unseen facade is an edge of a structure's outline (the convex hull
//     of one cluster of facade cells) that no point lies on and no sight
//     line crosses: the structure goes on there, and nobody has looked;
//   - a facade seen from one direction only is a run of facade cells whose
//     views all fall in one sector;
//   - a gap between components is the shortest stretch between the
//     largest component's photos and another's.
// Each yields a suggested position and heading; suggestions are ranked by
// how much of the site they would add (and, given a scout's position, how
// near they are). docs/coverage.md has the method and its limits.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "arscout/engine/model.h"

namespace arscout::engine {

struct CoverageOptions {
  // The ground cells' edge, metres: fine enough that a small building's
  // sides fall in different cells. Grows for large sites (below).
  double cell_m = 1.0;
  // The grid has at most this many cells along each side (the cell edge
  // grows to fit): the analysis costs the model's observations plus the
  // grid, whatever the site's extent.
  int max_cells_per_side = 400;
  int max_suggestions = 5;
  // Photos are taken this high above the ground: the ground is the plane
  // through the photos' heights less this (level when the photos lie
  // along a line), and points within min_facade_height_m of it are
  // ground, not facade.
  double camera_height_m = 1.6;
  double min_facade_height_m = 1.0;
  double min_unseen_facade_m = 4.0;  // shorter outline edges are ignored
  // The scout's position (ENU metres, east and north): nearer suggestions
  // rank higher. Absent: ranked by what they add alone.
  std::optional<std::array<double, 2>> near;
};

// A ground cell that holds facade. Directions are compass bearings
// (degrees clockwise from north); sector k covers bearings within 22.5
// degrees of 45 k.
struct CoverageCell {
  int column = 0, row = 0;         // in the grid (column east, row north)
  std::array<double, 2> centre{};  // ENU metres
  int points = 0;
  int views = 0;  // distinct registered photos that see its points
  std::array<int, 8> sectors{};  // distinct photos per sector
  int directions = 0;            // sectors with at least one photo
  // The bearing the facade faces (from its points toward the photos that
  // see them, averaged).
  double facing_deg = 0;
};

// An outline edge that nothing was seen on: from, to in ENU metres.
struct UnseenFacade {
  std::array<double, 2> from{}, to{};
  double length_m = 0;
  double facing_deg = 0;  // bearing of its outward side
};

struct ShotSuggestion {
  std::array<double, 2> position{};  // where to stand, ENU metres
  double heading_deg = 0;            // which way to look, compass bearing
  // "unseen_facade", "one_direction" or "component_gap".
  std::string kind;
  std::string reason;  // for the scout, e.g. "north facade seen from one
                       // direction only"
  double score = 0;    // larger first; comparable within one analysis
};

struct Coverage {
  double cell_m = 0;
  std::array<double, 2> grid_origin{};  // the grid's south-west corner, ENU
  int columns = 0, rows = 0;
  double ground_z = 0;    // ENU height of the ground under the photos
  double standoff_m = 0;  // median distance from photo to what it sees
  std::vector<CoverageCell> cells;  // facade cells, row-major order
  std::vector<UnseenFacade> unseen;
  std::vector<ShotSuggestion> suggestions;  // best first
};

// The coverage of `model`. Throws std::invalid_argument when the model is
// not geo-registered (only then are its units metres and its z up). An
// empty model gives an empty coverage.
Coverage analyse_coverage(const Model& model,
                          const CoverageOptions& options = {});

// The suggestions of `coverage` ranked for a scout at `near` (ENU metres:
// a suggestion four standoffs away counts half; none: as they are), at
// most `max`. analyse_coverage ranks by options.near with it, so a server
// may analyse a model version once, with every suggestion kept
// (max_suggestions large, no `near`), and rank it for each scout.
std::vector<ShotSuggestion> rank_for(
    const Coverage& coverage, const std::optional<std::array<double, 2>>& near,
    int max);

// "north", "north-east", ... for a compass bearing in degrees.
std::string compass_name(double bearing_deg);

}  // namespace arscout::engine
