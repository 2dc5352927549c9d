// Unit tests of the dense-cloud measures: planes and views with known
// answers, the depth images computed here by ray-plane intersection.
#include "dense_eval.h"

#include <cmath>
#include <random>
#include <stdexcept>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

namespace ev = arscout::eval;
using Eigen::Matrix3d;
using Eigen::Vector3d;

namespace {

// The wall x in [0, 4], z in [0, 3] in the plane y = 5.
ev::Parallelogram wall() {
  return {Vector3d(0, 5, 0), Vector3d(4, 0, 0), Vector3d(0, 0, 3)};
}

// A camera at `centre` looking north (+y), level: camera x east, y down.
ev::DepthView north_view(const Vector3d& centre, int width = 160,
                         int height = 120, double focal = 100) {
  ev::DepthView view;
  view.K << focal, 0, (width - 1) / 2.0, 0, focal, (height - 1) / 2.0, 0, 0, 1;
  view.R << 1, 0, 0, 0, 0, -1, 0, 1, 0;
  view.t = -view.R * centre;
  view.width = width, view.height = height;
  return view;
}

// The depth images of `views` against `surfaces` (nearest hit per pixel
// centre), solved with the same parallelogram test as the truth's.
void fill_depths(std::vector<ev::DepthView>& views,
                 const std::vector<ev::Parallelogram>& surfaces) {
  for (ev::DepthView& view : views) {
    view.depth.assign(static_cast<std::size_t>(view.width) * view.height, 0);
    const Vector3d centre = -view.R.transpose() * view.t;
    for (int row = 0; row < view.height; ++row)
      for (int col = 0; col < view.width; ++col) {
        const Vector3d ray =
            view.R.transpose() * (view.K.inverse() * Vector3d(col, row, 1));
        double nearest = 0;
        for (const auto& q : surfaces) {
          Matrix3d system;
          system << q.edge_u, q.edge_v, -ray;
          const Vector3d std = system.partialPivLu().solve(centre - q.corner);
          if (std(0) < 0 || std(0) > 1 || std(1) < 0 || std(1) > 1 ||
              std(2) <= 0)
            continue;
          if (nearest == 0 || std(2) < nearest) nearest = std(2);
        }
        view.depth[row * view.width + col] = static_cast<float>(nearest);
      }
  }
}

}  // namespace

TEST(DenseEval, DistanceToAParallelogramInsideBeyondAnEdgeAndAtACorner) {
  const ev::Parallelogram q = wall();
  EXPECT_NEAR(ev::distance_to(q, Vector3d(2, 3, 1)), 2.0, 1e-12);
  EXPECT_NEAR(ev::distance_to(q, Vector3d(2, 5.5, 1)), 0.5, 1e-12);
  // Beyond the top edge by 1 m, 1 m in front: sqrt(2).
  EXPECT_NEAR(ev::distance_to(q, Vector3d(2, 4, 4)), std::sqrt(2.0), 1e-12);
  // Off the corner (4, 5, 3) by (1, 2, 2): 3.
  EXPECT_NEAR(ev::distance_to(q, Vector3d(5, 7, 5)), 3.0, 1e-12);
  // A slanted parallelogram (edges not orthogonal): a point above its
  // inside is at its height over the plane.
  const ev::Parallelogram slanted{Vector3d::Zero(), Vector3d(2, 0, 0),
                                  Vector3d(1, 1, 0)};
  EXPECT_NEAR(ev::distance_to(slanted, Vector3d(1.5, 0.5, 0.3)), 0.3, 1e-12);
  EXPECT_NEAR(ev::distance_to(slanted, Vector3d(0, 1, 0)), std::sqrt(0.5),
              1e-12);
  const ev::Parallelogram flat{Vector3d::Zero(), Vector3d(1, 0, 0),
                               Vector3d(2, 0, 0)};
  EXPECT_NEAR(ev::distance_to(flat, Vector3d(1, 1, 0)), 1.0, 1e-12);
}

TEST(DenseEval, SurfaceDistanceIsTheNearestOfAllSurfaces) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-10, 10);
  std::vector<ev::Parallelogram> surfaces;
  for (int i = 0; i < 40; ++i)
    surfaces.push_back({Vector3d(u(rng), u(rng), u(rng)),
                        Vector3d(u(rng), u(rng), 0) / 4,
                        Vector3d(0, u(rng), u(rng)) / 4});
  const ev::SurfaceDistance truth(surfaces);
  for (int i = 0; i < 500; ++i) {
    const Vector3d p(u(rng), u(rng), u(rng));
    double brute = std::numeric_limits<double>::infinity();
    for (const auto& q : surfaces)
      brute = std::min(brute, ev::distance_to(q, p));
    ASSERT_DOUBLE_EQ(truth(p), brute);
  }
  EXPECT_TRUE(std::isinf(ev::SurfaceDistance({})(Vector3d::Zero())));
}

TEST(DenseEval, AccuracyCountsEachPointsDistance) {
  const ev::SurfaceDistance truth({wall()});
  std::vector<Vector3d> points;
  for (int i = 0; i < 10; ++i)  // 0.5, 1.5, ..., 9.5 cm in front of the wall
    points.emplace_back(1, 5 - 0.01 * i - 0.005, 1);
  const auto f = ev::measure_accuracy(points, truth, 0.05);
  EXPECT_EQ(f.points, 10);
  EXPECT_NEAR(f.median_m, 0.05, 1e-9);
  EXPECT_NEAR(f.p90_m, 0.086, 1e-9);
  EXPECT_DOUBLE_EQ(f.within_share, 0.5);
  EXPECT_EQ(ev::measure_accuracy({}, truth).points, 0);
}

TEST(DenseEval, CompletenessIsTheSeenSurfaceThatHasAPointNearIt) {
  const std::vector<ev::Parallelogram> surfaces = {wall()};
  std::vector<ev::DepthView> views = {north_view(Vector3d(1.5, 0, 1.5)),
                                      north_view(Vector3d(2.5, 0, 1.5))};
  fill_depths(views, surfaces);
  // Points on the wall's left half, every 2 cm.
  std::vector<Vector3d> points;
  for (double x = 0.01; x < 2; x += 0.02)
    for (double z = 0.01; z < 3; z += 0.02) points.emplace_back(x, 5, z);
  ev::CompletenessOptions options;
  options.spacing_m = 0.05;
  const auto f = ev::measure_completeness(surfaces, views, points, options);
  EXPECT_EQ(f.samples, 80 * 60);
  EXPECT_GT(f.seen, 0.9 * f.samples);  // both views see nearly all of it
  EXPECT_NEAR(f.share, 0.5, 0.03);
  // Two views are asked for: with one view, nothing counts as seen.
  views.pop_back();
  EXPECT_EQ(ev::measure_completeness(surfaces, views, points, options).seen, 0);
}

TEST(DenseEval, CompletenessIsSplitByHowManyViewsSeeEachSample) {
  // Two views 5 m away see the whole wall; a third 2 m away sees about
  // x in [1.9, 4], z in [0.3, 2.7]. Points cover the left half only.
  std::vector<ev::DepthView> views = {north_view(Vector3d(1.5, 0, 1.5)),
                                      north_view(Vector3d(2.5, 0, 1.5)),
                                      north_view(Vector3d(3.5, 3, 1.5))};
  fill_depths(views, {wall()});
  std::vector<Vector3d> points;
  for (double x = 0.01; x < 2; x += 0.02)
    for (double z = 0.01; z < 3; z += 0.02) points.emplace_back(x, 5, z);
  const auto f = ev::measure_completeness({wall()}, views, points);
  int64_t seen = 0, covered = 0;
  for (int k = 0; k <= ev::kMostViewsCounted; ++k) {
    seen += f.seen_by_views[k];
    covered += f.covered_by_views[k];
    EXPECT_LE(f.covered_by_views[k], f.seen_by_views[k]);
    if (k != 2 && k != 3) {
      EXPECT_EQ(f.seen_by_views[k], 0) << k;
    }
  }
  EXPECT_EQ(seen, f.seen);
  EXPECT_EQ(covered, f.covered);
  // The third view's part: about 2.1 x 2.4 m of the 12 m^2.
  EXPECT_NEAR(static_cast<double>(f.seen_by_views[3]) / f.seen, 0.42, 0.05);
  // The covered left half lies almost wholly in the two views' part.
  EXPECT_LT(f.covered_by_views[3], 0.1 * f.seen_by_views[3]);
  EXPECT_GT(f.covered_by_views[2], 0.75 * f.seen_by_views[2]);
}

TEST(DenseEval, CompletenessLeavesOutWhatIsHiddenOrSeenTooCoarsely) {
  // A screen 1 m in front of the wall's right half hides it from both views.
  const ev::Parallelogram screen{Vector3d(2, 4, 0), Vector3d(3, 0, 0),
                                 Vector3d(0, 0, 4)};
  std::vector<ev::DepthView> views = {north_view(Vector3d(1.5, 0, 1.5)),
                                      north_view(Vector3d(2.5, 0, 1.5))};
  fill_depths(views, {wall(), screen});
  std::vector<Vector3d> points;
  for (double x = 0.01; x < 2; x += 0.02)
    for (double z = 0.01; z < 3; z += 0.02) points.emplace_back(x, 5, z);
  const auto hidden = ev::measure_completeness({wall()}, views, points);
  // Only the left half is seen, and it is all covered.
  EXPECT_LT(hidden.seen, 0.55 * hidden.samples);
  EXPECT_GT(hidden.share, 0.97);
  // At 5 m, a focal of 50 px gives 10 cm pixels: nothing is resolved.
  ev::CompletenessOptions coarse;
  coarse.footprint_focal_px = 50;
  coarse.max_footprint_m = 0.05;
  EXPECT_EQ(ev::measure_completeness({wall()}, views, points, coarse).seen, 0);
  coarse.footprint_focal_px = 500;  // 1 cm pixels
  EXPECT_EQ(ev::measure_completeness({wall()}, views, points, coarse).seen,
            hidden.seen);
}

TEST(DenseEval, CompletenessRejectsDepthImagesOfTheWrongSize) {
  std::vector<ev::DepthView> views = {north_view(Vector3d(1.5, 0, 1.5))};
  views[0].depth.assign(10, 1.0f);
  EXPECT_THROW(ev::measure_completeness({wall()}, views, {}),
               std::invalid_argument);
}

TEST(DenseEval, SkyColouredIsBrightBlueOnly) {
  EXPECT_TRUE(ev::sky_coloured(151, 168, 213));   // fountain-P11's stray sky
  EXPECT_TRUE(ev::sky_coloured(120, 170, 235));   // clear sky
  EXPECT_FALSE(ev::sky_coloured(128, 128, 128));  // grey
  EXPECT_FALSE(ev::sky_coloured(240, 240, 245));  // nearly white
  EXPECT_FALSE(ev::sky_coloured(170, 90, 60));    // brick
  EXPECT_FALSE(ev::sky_coloured(20, 30, 90));     // dark blue: too dark
  EXPECT_FALSE(ev::sky_coloured(90, 200, 90));    // green
}

// A 2 x 1 m patch of ground 1.6 m below the cameras, sampled every 2.5 cm
// (one point per 5 cm cell and three more), a wall above it and a few
// points 1 m lower: the ground's 2 m^2 are found, nothing else.
TEST(DenseEval, GroundCoverIsTheAreaAtTheCamerasDrop) {
  const std::vector<Vector3d> cameras = {Vector3d(0, 0, 11.6),
                                         Vector3d(4, 0, 11.6)};
  std::vector<ev::CloudPoint> points;
  for (int i = 0; i < 80; ++i)
    for (int j = 0; j < 40; ++j)
      points.push_back({Vector3d(0.0125 + 0.025 * i, 2.0125 + 0.025 * j, 10)});
  for (int i = 0; i < 500; ++i)
    points.push_back({Vector3d(0.01 * i, 5, 10.5 + 0.004 * i)});
  for (int i = 0; i < 20; ++i) points.push_back({Vector3d(0.1 * i, 4, 9)});
  EXPECT_NEAR(ev::ground_cover_m2(points, cameras), 2.0, 1e-9);
  EXPECT_NEAR(ev::ground_cover_m2(points, cameras, 0.1), 2.0, 1e-9);
  EXPECT_EQ(ev::ground_cover_m2({}, cameras), 0);
  EXPECT_EQ(ev::ground_cover_m2(points, {}), 0);
}

TEST(DenseEval, PlausibilityFlagsFarHighLowAndSkyPoints) {
  const std::vector<Vector3d> cameras = {Vector3d(0, 0, 1.6),
                                         Vector3d(10, 0, 1.6)};
  auto point = [](double x, double y, double z, uint8_t r = 100,
                  uint8_t g = 100, uint8_t b = 100) {
    return ev::CloudPoint{Vector3d(x, y, z), r, g, b};
  };
  const std::vector<ev::CloudPoint> points = {
      point(5, 8, 3),                    // a facade: plausible
      point(10, 45, 3),                  // 45 m from the nearest camera
      point(0, 5, 40),                   // 38.4 m above
      point(10, 3, -5),                  // 6.6 m below
      point(5, 8, 5, 151, 168, 213),     // sky-coloured
      point(0, 50, 50, 151, 168, 213)};  // far, high and sky
  const auto f = ev::measure_plausibility(points, cameras);
  EXPECT_EQ(f.points, 6);
  EXPECT_DOUBLE_EQ(f.far_share, 2 / 6.0);
  EXPECT_DOUBLE_EQ(f.above_share, 2 / 6.0);
  EXPECT_DOUBLE_EQ(f.below_share, 1 / 6.0);
  EXPECT_DOUBLE_EQ(f.sky_share, 2 / 6.0);
  EXPECT_DOUBLE_EQ(f.implausible_share, 5 / 6.0);
  EXPECT_THROW(ev::measure_plausibility(points, {}), std::invalid_argument);
}
