// Coverage guidance (coverage.h) on models built here with exact geometry:
// a 20 x 12 m building whose facades are walked round on some sides, each
// point observed by the photos that face it within range.
#include <cmath>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

#include "arscout/engine/coverage.h"

namespace arscout::engine {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kStandoff = 7;  // metres from the walk to the facade

struct Side {
  std::array<double, 2> from, to;  // along the facade, building on the left
  std::array<double, 2> outward;   // unit
};

// The building x -10..10, y -6..6, counter-clockwise.
const Side kSouth{{-10, -6}, {10, -6}, {0, -1}};
const Side kEast{{10, -6}, {10, 6}, {1, 0}};
const Side kNorth{{10, 6}, {-10, 6}, {0, 1}};
const Side kWest{{-10, 6}, {-10, -6}, {-1, 0}};

struct Photo {
  std::array<double, 3> centre;
  std::array<double, 2> looking;  // unit, horizontal
};

Model empty_model() {
  Model model;
  model.geo_registered = true;
  model.enu_origin = Geodetic{55.7, 13.2, 30};
  model.cameras.push_back({"cam", {}});
  return model;
}

// Photos every 1.5 m along a side, 4 m past each corner, facing it.
std::vector<Photo> walk(const Side& side) {
  std::vector<Photo> photos;
  const double dx = side.to[0] - side.from[0], dy = side.to[1] - side.from[1];
  const double length = std::hypot(dx, dy);
  for (double s = -4; s <= length + 4; s += 1.5) {
    const double x =
        side.from[0] + s * dx / length + kStandoff * side.outward[0];
    const double y =
        side.from[1] + s * dy / length + kStandoff * side.outward[1];
    photos.push_back({{x, y, 1.6}, {-side.outward[0], -side.outward[1]}});
  }
  return photos;
}

// Whether a photo sees a facade point with that outward normal: in front of
// it, within 15 m, within 50 degrees of where the photo looks.
bool sees(const Photo& photo, const std::array<double, 3>& p,
          const std::array<double, 2>& outward) {
  const double vx = p[0] - photo.centre[0], vy = p[1] - photo.centre[1];
  const double range = std::hypot(vx, vy);
  if (-(vx * outward[0] + vy * outward[1]) < 0.5 || range > 15) return false;
  const double c = (vx * photo.looking[0] + vy * photo.looking[1]) / range;
  return c > std::cos(50 * kPi / 180);
}

// Points every 0.5 m along each facade in `seen` at heights 1-7 m and on
// the ground in front of it, observed by every photo that sees them.
Model building(const std::vector<Side>& seen,
               const std::vector<Photo>& photos) {
  Model model = empty_model();
  for (const Photo& photo : photos) {
    ModelImage image;
    image.id = std::to_string(model.images.size());
    image.centre = photo.centre;
    model.images.push_back(image);
  }
  for (const Side& side : seen) {
    const double dx = side.to[0] - side.from[0], dy = side.to[1] - side.from[1];
    for (double t = 0; t <= 1.0001; t += 0.5 / std::hypot(dx, dy))
      for (double z : {0.0, 1.0, 3.0, 5.0, 7.0}) {
        const double out = z == 0 ? 2 : 0;  // ground: 2 m in front
        ModelPoint p;
        p.id = static_cast<int64_t>(model.points.size());
        p.xyz = {side.from[0] + t * dx + out * side.outward[0],
                 side.from[1] + t * dy + out * side.outward[1], z};
        for (std::size_t i = 0; i < photos.size(); ++i)
          if (sees(photos[i], p.xyz, side.outward))
            p.track.emplace_back(static_cast<int>(i), 0);
        if (p.track.size() >= 2) model.points.push_back(p);
      }
  }
  model.components.push_back({0, static_cast<int>(model.images.size()),
                              static_cast<int>(model.points.size())});
  return model;
}

std::vector<Photo> walks(const std::vector<Side>& sides) {
  std::vector<Photo> all;
  for (const Side& side : sides)
    for (const Photo& p : walk(side)) all.push_back(p);
  return all;
}

double bearing_gap(double a, double b) {
  return std::abs(std::remainder(a - b, 360.0));
}

TEST(Coverage, TheFirstSuggestionFacesTheFacadeNobodyPhotographed) {
  const std::vector<Side> sides{kEast, kNorth, kWest};
  const Coverage c = analyse_coverage(building(sides, walks(sides)));
  ASSERT_FALSE(c.suggestions.empty());
  const ShotSuggestion& first = c.suggestions.front();
  EXPECT_EQ(first.kind, "unseen_facade") << first.reason;
  EXPECT_EQ(first.reason, "the south side has never been photographed");
  // In front of the south facade's middle, looking north at it.
  EXPECT_LT(std::hypot(first.position[0] - 0, first.position[1] + 13), 10);
  EXPECT_LT(bearing_gap(first.heading_deg, 0), 45) << first.heading_deg;
  ASSERT_FALSE(c.unseen.empty());
  EXPECT_NEAR(c.unseen.front().facing_deg, 180, 10);
  EXPECT_GT(c.unseen.front().length_m, 15);
  EXPECT_NEAR(c.ground_z, 0, 1e-9);
  EXPECT_NEAR(c.standoff_m, 9, 3);
  // The facades seen have cells; the unseen one has none.
  int south_cells = 0, north_cells = 0;
  for (const CoverageCell& cell : c.cells) {
    south_cells += cell.centre[1] < -6 - c.cell_m;
    north_cells += cell.centre[1] > 6 - c.cell_m && cell.views > 0;
    EXPECT_GT(cell.views, 0);
    EXPECT_GE(cell.directions, 1);
  }
  EXPECT_EQ(south_cells, 0);
  EXPECT_GT(north_cells, 5);
}

TEST(Coverage, ABuildingSeenAllRoundHasNoUnseenFacade) {
  const std::vector<Side> sides{kSouth, kEast, kNorth, kWest};
  const Coverage c = analyse_coverage(building(sides, walks(sides)));
  EXPECT_TRUE(c.unseen.empty());
  for (const ShotSuggestion& s : c.suggestions)
    EXPECT_NE(s.kind, "unseen_facade") << s.reason;
}

TEST(Coverage, AFacadeSeenFromOneSpotAsksForASecondDirection) {
  // Six photos from one spot 7 m north of the facade's middle.
  std::vector<Photo> photos;
  for (int k = 0; k < 6; ++k)
    photos.push_back({{0.2 * k, 6 + kStandoff, 1.6}, {0, -1}});
  const Coverage c = analyse_coverage(building({kNorth}, photos));
  bool asked = false;
  for (const ShotSuggestion& s : c.suggestions) {
    if (s.kind != "one_direction") continue;
    asked = true;
    // A standpoint north of the facade, not where the photos were taken,
    // looking back south at it.
    EXPECT_GT(s.position[1], 6);
    EXPECT_GT(std::hypot(s.position[0] - 0.5, s.position[1] - 13), 2);
    EXPECT_LT(bearing_gap(s.heading_deg, 180), 90) << s.heading_deg;
    EXPECT_NE(s.reason.find("seen from one direction only"), std::string::npos);
  }
  EXPECT_TRUE(asked);
}

TEST(Coverage, AGapBetweenComponentsComesFirst) {
  const std::vector<Side> sides{kEast, kNorth, kWest};
  Model model = building(sides, walks(sides));
  // A second component: three photos 60 m east.
  for (int k = 0; k < 3; ++k) {
    ModelImage image;
    image.id = "far" + std::to_string(k);
    image.centre = {70.0 + k, 0, 1.6};
    image.component = 1;
    model.images.push_back(image);
  }
  model.components.push_back({1, 3, 0});
  const Coverage c = analyse_coverage(model);
  ASSERT_FALSE(c.suggestions.empty());
  const ShotSuggestion& first = c.suggestions.front();
  EXPECT_EQ(first.kind, "component_gap");
  // Halfway between the east walk (x = 17) and the nearest far photo.
  EXPECT_NEAR(first.position[0], (17 + 70) / 2.0, 1);
  EXPECT_LT(bearing_gap(first.heading_deg, 90), 10);
}

TEST(Coverage, NearerSuggestionsRankFirstGivenTheScoutsPosition) {
  const std::vector<Side> sides{kEast, kNorth, kWest};
  const Model model = building(sides, walks(sides));
  CoverageOptions options;
  options.near = std::array<double, 2>{0, -13};
  const Coverage near = analyse_coverage(model, options);
  ASSERT_FALSE(near.suggestions.empty());
  EXPECT_EQ(near.suggestions.front().kind, "unseen_facade");
  options.max_suggestions = 1;
  EXPECT_EQ(analyse_coverage(model, options).suggestions.size(), 1u);
}

TEST(Coverage, RefusesALocalModelAndBoundsItsGrid) {
  Model local = empty_model();
  local.geo_registered = false;
  EXPECT_THROW(analyse_coverage(local), std::invalid_argument);
  EXPECT_TRUE(analyse_coverage(empty_model()).cells.empty());
  // Photos 20 km apart: the cell grows, the grid stays within its bound.
  const std::vector<Side> sides{kEast, kNorth, kWest};
  Model wide = building(sides, walks(sides));
  ModelImage far;
  far.id = "far";
  far.centre = {20000, 20000, 1.6};
  wide.images.push_back(far);
  CoverageOptions options;
  const Coverage c = analyse_coverage(wide, options);
  EXPECT_LE(c.columns, options.max_cells_per_side + 1);
  EXPECT_LE(c.rows, options.max_cells_per_side + 1);
  EXPECT_GT(c.cell_m, 50);
}

TEST(Coverage, CompassNames) {
  EXPECT_EQ(compass_name(0), "north");
  EXPECT_EQ(compass_name(359), "north");
  EXPECT_EQ(compass_name(91), "east");
  EXPECT_EQ(compass_name(-45), "north-west");
  EXPECT_EQ(compass_name(200), "south");
}

}  // namespace
}  // namespace arscout::engine
