// The ground grid under the coverage analysis (coverage.h): facade cells
// with the photos that see them by direction, and the cells that sight
// lines cross (seen empty).
#pragma once

#include <array>
#include <utility>
#include <vector>

#include "arscout/engine/coverage.h"
#include "arscout/engine/model.h"

namespace arscout::engine::guidance {

using Vec2 = std::array<double, 2>;

// Compass bearing (degrees clockwise from north) of an ENU direction.
double bearing_of(const Vec2& direction);
Vec2 unit_of_bearing(double bearing_deg);
// The 45-degree sector (0 = north, clockwise) a bearing falls in.
int sector_of(double bearing_deg);
double distance(const Vec2& a, const Vec2& b);

// One sparse point as the analysis sees it: where it is and which
// registered photos (indices into Model::images) observe it.
struct Sighted {
  Vec2 xy{};
  double z = 0;
  std::vector<int> images;
  bool facade = false;  // above the ground (CoverageOptions)
};

// A square grid; cells are numbered row-major from the south-west corner.
struct Grid {
  Vec2 origin{};
  double cell = 1;
  int columns = 0, rows = 0;

  int index(const Vec2& p) const;  // -1 outside
  Vec2 centre(int i) const;
  int size() const { return columns * rows; }
};

struct CellState {
  int points = 0;                              // facade points in it
  std::vector<std::pair<int, int>> sightings;  // (sector, image)
  Vec2 facing{};  // summed unit directions toward the photos
  bool seen_empty = false;
};

struct GroundGrid {
  std::vector<Sighted> points;
  // The ground: z = a x + b y + c through the photos' heights less the
  // camera height (a level plane when the photos lie along a line). A
  // plane rather than one height: a model placed by GPS fixes with metres
  // of vertical noise can lean by a degree or more, which over a block is
  // as much as the facade threshold.
  std::array<double, 3> ground{0, 0, 0};
  double ground_z = 0;  // at the photos' centroid
  double standoff = 0;  // median photo-to-facade distance, metres
  Grid grid;
  std::vector<CellState> cells;
  // Every sight line carved (at most kMaxSightLines, evenly thinned):
  // (index into Model::images, index into points), and the photos' ground
  // positions by image index.
  std::vector<std::pair<int, int>> sight_lines;
  std::vector<Vec2> cameras;

  double ground_at(const Vec2& p) const {
    return ground[0] * p[0] + ground[1] * p[1] + ground[2];
  }
  bool facade_cell(int i) const { return i >= 0 && cells[i].points > 0; }
  // Cell i or one of its 8 neighbours holds facade.
  bool facade_near(int i) const;
};

// The grid of a geo-registered model (coverage.h's options).
GroundGrid build_ground_grid(const Model& model,
                             const CoverageOptions& options);

// The public form of facade cell i.
CoverageCell summarise_cell(const GroundGrid& g, int i);

Vec2 centre_xy(const ModelImage& image);

}  // namespace arscout::engine::guidance
