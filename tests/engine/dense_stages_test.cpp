// The dense stages one at a time (sweep directions, the forward-backward
// consistency check, depth-map comparison, voxel fusion, point rendering)
// and DenseReconstruction driven incrementally by a hand-built sparse Model,
// on small rendered street scenes with exact depth (synthetic_site.h).
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <optional>
#include <random>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "arscout/engine/dense.h"
#include "arscout/engine/dense_reconstruction.h"
#include "arscout/engine/ply.h"
#include "arscout/engine/point_render.h"
#include "arscout/engine/reconstruction.h"
#include "arscout/engine/synthetic_site.h"
#include "dense/consistency.h"
#include "dense/depth_map_io.h"
#include "dense/depth_normals.h"
#include "dense/sky_mask.h"
#include "rendered_street.h"

namespace arscout::engine {
namespace {

namespace syn = synthetic;
using namespace street_fixture;

constexpr int kViews = kStreetViews;
constexpr int kWidth = 320;
constexpr int kHeight = 240;
constexpr double kFocal = 280;         // rendered_street(): 560 px per 640 px
constexpr double kCameraHeight = 1.6;  // street_cameras()

// The five converging street views at 320 x 240 (rendered_street.h).
const std::vector<Rendered>& street() {
  return rendered_street({kWidth, kHeight});
}

// An exact depth map: the rendering's ground truth with its camera.
DepthMap truth_map(const Rendered& r, const std::string& id) {
  DepthMap map;
  map.id = id;
  map.depth = r.image.depth.clone();
  map.K = r.view.K;
  map.R = r.view.R;
  map.t = r.view.t;
  return map;
}

int count_where(const cv::Mat& mask) { return cv::countNonZero(mask); }

// ---------------------------------------------------------------------------
// depth_normals

// The nearest surface of the street to X, and its unit normal facing `eye`.
std::pair<double, Eigen::Vector3d> nearest_surface(const Eigen::Vector3d& X,
                                                   const Eigen::Vector3d& eye);

// On an exact map, the fitted planes are the street's own surfaces.
TEST(DenseStagesNormals, ExactDepthsGiveTheSurfacesNormals) {
  const Rendered& r = street()[2];
  const DepthMap map = truth_map(r, "view2");
  const cv::Mat normals = depth_normals(map.depth, map.K, 4);
  ASSERT_EQ(normals.type(), CV_32FC3);
  int compared = 0, within_2deg = 0;
  for (int y = 0; y < map.depth.rows; y += 3) {
    for (int x = 0; x < map.depth.cols; x += 3) {
      const float z = map.depth.at<float>(y, x);
      const cv::Vec3f n = normals.at<cv::Vec3f>(y, x);
      if (z <= 0) {
        EXPECT_EQ(cv::norm(n), 0);
        continue;
      }
      const Eigen::Vector3d X = map.unproject(x, y, z);
      const Eigen::Vector3d world =
          map.R.transpose() * Eigen::Vector3d(n[0], n[1], n[2]);
      const auto [distance, truth] = nearest_surface(X, r.view.centre());
      ++compared;
      within_2deg += world.dot(truth) > std::cos(2 * M_PI / 180);
    }
  }
  // Pixels within the window of an edge between two surfaces fit neither.
  EXPECT_GE(within_2deg, 0.85 * compared) << within_2deg << " / " << compared;
}

// ---------------------------------------------------------------------------
// without_isolated_points

// A wall sampled every voxel (1 cm) keeps every point, its edges and
// corners included; floaters standing alone, or in pairs, 10 cm and more
// from anything, are dropped.
TEST(DenseStagesIsolatedPoints, FloatersGoTheSurfaceStays) {
  const double voxel = 0.01;
  std::vector<ColoredPoint> points;
  for (int i = 0; i < 100; ++i)
    for (int j = 0; j < 60; ++j)
      points.push_back({static_cast<float>(i * voxel), 5,
                        static_cast<float>(j * voxel), 1, 2, 3});
  const size_t wall = points.size();
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> across(-3, 3);
  for (int k = 0; k < 200; ++k) {
    ColoredPoint p{across(rng), 2 + across(rng) / 10, 1 + across(rng), 9, 9, 9};
    points.push_back(p);
    if (k % 2) {  // a pair: one neighbour is not enough
      p.x += 0.5f * voxel;
      points.push_back(p);
    }
  }
  const auto kept = without_isolated_points(
      points, kIsolatedRadiusVoxels * voxel, kIsolatedMinNeighbours);
  ASSERT_EQ(kept.size(), wall);
  for (size_t i = 0; i < wall; ++i) EXPECT_EQ(kept[i].x, points[i].x);
  EXPECT_EQ(without_isolated_points(points, 0.025, 0).size(), points.size());
  // Points no fusion makes, far off or not numbers, are dropped, not a
  // crash or an overflow.
  std::vector<ColoredPoint> odd = {{1e30f, 0, 0}, {-1e30f, 0, 0}};
  odd.push_back({std::numeric_limits<float>::infinity(), 0, 0});
  odd.push_back({std::numeric_limits<float>::quiet_NaN(), 0, 0});
  odd.insert(odd.end(), points.begin(), points.begin() + wall);
  EXPECT_EQ(without_isolated_points(odd, 0.025, 2).size(), wall);
  EXPECT_TRUE(without_isolated_points({}, 0.025, 2).empty());
  EXPECT_THROW(without_isolated_points(points, 0, 2), std::invalid_argument);
}

// ---------------------------------------------------------------------------
// sweep_directions

class DenseStagesSweepDirections : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto& s = street();
    for (int i = 1; i <= 3; ++i)
      views_.push_back(
          dense_view(s[i], view_id(i), sample_surface(s[i], 400, 20 + i)));
  }
  const DenseView& key() const { return views_[1]; }
  std::vector<const DenseView*> neighbours() const {
    return {&views_[0], &views_[2]};
  }
  std::vector<DenseView> views_;
};

TEST_F(DenseStagesSweepDirections, FrontoParallelFirstBracketingTheDepths) {
  PlaneSweepOptions options;
  options.max_scene_directions = 0;
  const auto directions = sweep_directions(key(), neighbours(), options);
  ASSERT_EQ(directions.size(), 1u);
  const SweepDirection& fronto = directions[0];
  EXPECT_EQ(fronto.normal, Eigen::Vector3d(Eigen::Vector3d::UnitZ()));
  EXPECT_GT(fronto.d_near, 0);
  EXPECT_GT(fronto.d_far, fronto.d_near);
  EXPECT_GE(fronto.planes, options.min_planes);
  EXPECT_LE(fronto.planes, options.max_planes);
  // Every sparse depth and every true depth the key sees lies in range.
  for (const Eigen::Vector3d& X : key().sparse_points) {
    const double z = (key().R * X + key().t).z();
    EXPECT_GE(z, fronto.d_near);
    EXPECT_LE(z, fronto.d_far);
  }
  double lo = 0, hi = 0;
  cv::minMaxLoc(street()[2].image.depth, &lo, &hi, nullptr, nullptr,
                street()[2].image.depth > 0);
  EXPECT_LT(fronto.d_near, lo);
  EXPECT_GT(fronto.d_far, hi);
}

TEST_F(DenseStagesSweepDirections, SceneDirectionAlongTheGround) {
  PlaneSweepOptions options;
  options.max_scene_directions = 2;
  const auto directions = sweep_directions(key(), neighbours(), options);
  ASSERT_GE(directions.size(), 2u);
  ASSERT_LE(directions.size(), 3u);
  EXPECT_EQ(directions[0].normal, Eigen::Vector3d(Eigen::Vector3d::UnitZ()));
  // The world's up in the key frame.
  const Eigen::Vector3d up = key().R * Eigen::Vector3d::UnitZ();
  int ground = -1;
  for (size_t i = 1; i < directions.size(); ++i) {
    EXPECT_NEAR(directions[i].normal.norm(), 1, 1e-9);
    EXPECT_GT(directions[i].d_near, 0);
    EXPECT_GT(directions[i].d_far, directions[i].d_near);
    EXPECT_GE(directions[i].planes, options.min_planes);
    EXPECT_LE(directions[i].planes, options.max_planes);
    if (std::abs(directions[i].normal.dot(up)) > 0.98)
      ground = static_cast<int>(i);
  }
  ASSERT_GE(ground, 1) << "no sweep direction parallel to the ground";
  const SweepDirection& g = directions[ground];
  // Oriented so that offsets are positive: the ground lies below the camera,
  // at the camera's height along the (nearly exact) ground normal.
  EXPECT_LT(g.normal.dot(up), 0);
  EXPECT_LT(g.d_near, kCameraHeight);
  EXPECT_GT(g.d_far, kCameraHeight);
  int on_ground = 0;
  for (const Eigen::Vector3d& X : key().sparse_points) {
    if (std::abs(X.z()) > 1e-6) continue;
    ++on_ground;
    const double offset = g.normal.dot(key().R * X + key().t);
    EXPECT_GE(offset, g.d_near);
    EXPECT_LE(offset, g.d_far);
  }
  EXPECT_GT(on_ground, 30);
}

// With the world's up known, the ground gets a direction even where RANSAC
// is not asked for one, bracketing the camera's height.
TEST_F(DenseStagesSweepDirections, GroundDirectionFromTheWorldsUp) {
  PlaneSweepOptions options;
  options.max_scene_directions = 0;
  DenseView key_view = key();
  EXPECT_EQ(sweep_directions(key_view, neighbours(), options).size(), 1u);
  key_view.up = Eigen::Vector3d::UnitZ();
  const auto directions = sweep_directions(key_view, neighbours(), options);
  ASSERT_EQ(directions.size(), 2u);
  const SweepDirection& g = directions[1];
  const Eigen::Vector3d up = key_view.R * Eigen::Vector3d::UnitZ();
  EXPECT_NEAR(g.normal.dot(up), -1, 1e-9);
  EXPECT_LT(g.d_near, kCameraHeight);
  EXPECT_GT(g.d_far, kCameraHeight);
  // The nearest plane is at least a quarter of the farthest (less the
  // margin), not at the bottom of a facade just below the camera.
  EXPECT_GE(g.d_near, g.d_far / 4 * (1 - options.depth_margin) - 1e-9);
  EXPECT_GE(g.planes, options.min_planes);
  EXPECT_LE(g.planes, options.max_planes);
  options.ground_direction = false;
  EXPECT_EQ(sweep_directions(key_view, neighbours(), options).size(), 1u);
}

// RANSAC's ground already sweeps the ground: no second one.
TEST_F(DenseStagesSweepDirections, NoGroundDirectionBesideAParallelOne) {
  PlaneSweepOptions options;
  options.max_scene_directions = 2;
  DenseView key_view = key();
  const size_t without_up =
      sweep_directions(key_view, neighbours(), options).size();
  key_view.up = Eigen::Vector3d::UnitZ();
  const auto directions = sweep_directions(key_view, neighbours(), options);
  EXPECT_EQ(directions.size(), without_up);
  const Eigen::Vector3d up = key_view.R * Eigen::Vector3d::UnitZ();
  const auto along_up = std::count_if(directions.begin(), directions.end(),
                                      [&](const SweepDirection& d) {
                                        return std::abs(d.normal.dot(up)) > 0.9;
                                      });
  EXPECT_EQ(along_up, 1);
}

// Two parallel walls on the right (key frame x = 2 and x = 3, the nearer
// one larger) and the ground below: the second wall adds no direction of
// its own, so the ground gets the second scene direction.
TEST_F(DenseStagesSweepDirections, ParallelPlanesShareOneDirection) {
  DenseView key_view = key();
  key_view.R = Eigen::Matrix3d::Identity();
  key_view.t = Eigen::Vector3d::Zero();
  key_view.sparse_points.clear();
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> along(4, 14), up(-1.5, 1.5);
  // One draw per statement (argument order is unspecified; compilers
  // differ, and so would the scene).
  for (int i = 0; i < 240; ++i) {
    const double y = up(rng), z = along(rng);
    key_view.sparse_points.emplace_back(2, y, z);
  }
  for (int i = 0; i < 180; ++i) {
    const double y = up(rng), z = along(rng);
    key_view.sparse_points.emplace_back(3, y, z);
  }
  for (int i = 0; i < 120; ++i) {
    const double x = up(rng), z = along(rng);
    key_view.sparse_points.emplace_back(x, 1.6, z);
  }
  DenseView left = key_view, right = key_view;
  left.t = Eigen::Vector3d(0.5, 0, 0);
  right.t = Eigen::Vector3d(-0.5, 0, 0);
  PlaneSweepOptions options;
  options.max_scene_directions = 2;
  const auto directions = sweep_directions(key_view, {&left, &right}, options);
  ASSERT_EQ(directions.size(), 3u);
  EXPECT_GT(directions[1].normal.x(), 0.99);  // the walls
  EXPECT_GT(directions[2].normal.y(), 0.99);  // the ground, below
  // The walls' direction spans the nearer wall, the larger one.
  EXPECT_LT(directions[1].d_near, 2);
  EXPECT_GT(directions[1].d_far, 2);
}

TEST_F(DenseStagesSweepDirections, EmptyWithTooFewSparsePointsOrNoBaseline) {
  const PlaneSweepOptions options;
  DenseView few = key();
  few.sparse_points.resize(7);
  EXPECT_TRUE(sweep_directions(few, neighbours(), options).empty());
  few.sparse_points = key().sparse_points;
  few.sparse_points.resize(8);
  EXPECT_EQ(sweep_directions(few, neighbours(), options).size(), 1u);
  // Points behind the camera do not count.
  DenseView behind = key();
  behind.sparse_points.clear();
  for (int i = 0; i < 20; ++i)
    behind.sparse_points.push_back(behind.centre() +
                                   Eigen::Vector3d(0.1 * i, -5, 1));
  EXPECT_TRUE(sweep_directions(behind, neighbours(), options).empty());
  EXPECT_TRUE(sweep_directions(key(), {}, options).empty());
}

// ---------------------------------------------------------------------------
// agreement_mask

TEST(DenseStagesAgreement, MapAgreesWithItselfWhereverItHasDepth) {
  DepthMap a = truth_map(street()[2], "a");
  // A hole without depth: never agrees.
  a.depth(cv::Rect(10, 10, 20, 15)).setTo(0);
  const DepthMap b = a;  // the same view, the same depths
  const cv::Mat mask = agreement_mask(a, b, {});
  ASSERT_EQ(mask.type(), CV_8U);
  ASSERT_EQ(mask.size(), a.depth.size());
  const cv::Mat has_depth = a.depth > 0;
  EXPECT_EQ(count_where(mask != has_depth), 0);
  EXPECT_EQ(count_where(mask(cv::Rect(10, 10, 20, 15))), 0);
  EXPECT_GT(count_where(mask), 0.9 * kWidth * kHeight);
  // On the calling thread alone: the same mask.
  ConsistencyOptions serial;
  serial.parallel = false;
  EXPECT_EQ(count_where(agreement_mask(a, b, serial) != mask), 0);
  // Only 0 and 255.
  EXPECT_EQ(count_where(mask == 0) + count_where(mask == 255),
            kWidth * kHeight);
}

TEST(DenseStagesAgreement, CorruptedDepthsDisagreeWithAnExactPartner) {
  const auto& s = street();
  DepthMap a = truth_map(s[2], "a");
  const DepthMap partner = truth_map(s[3], "partner");
  const cv::Rect patch(140, 40, 40, 40);  // on the facade
  cv::Mat corrupted = a.depth(patch);
  corrupted *= 1.1;
  const cv::Mat mask = agreement_mask(a, partner, {});
  EXPECT_EQ(count_where(mask(patch)), 0);
  // Elsewhere, the pixels the partner sees agree (up to its pixel grid on
  // steep surfaces).
  int visible = 0, agreeing = 0;
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      if (patch.contains({x, y}) || a.depth.at<float>(y, x) <= 0) continue;
      if (!seen_at(s[3], surface_point(s[2], x, y), 1)) continue;
      ++visible;
      if (mask.at<uint8_t>(y, x)) ++agreeing;
    }
  }
  ASSERT_GT(visible, 0.5 * kWidth * kHeight);
  EXPECT_GE(agreeing, 0.97 * visible);
  // A looser tolerance than the error lets the patch through.
  ConsistencyOptions loose;
  loose.max_relative_depth = 0.5;
  loose.max_reprojection_px = 1e6;
  EXPECT_GT(count_where(agreement_mask(a, partner, loose)(patch)),
            0.9 * patch.area());
}

TEST(DenseStagesAgreement, PixelsLandingOutsideThePartnerDoNotAgree) {
  // The partner stands at the key's pose with the principal point 100 px to
  // the right: key pixel (x, y) lands exactly on (x + 100, y) there, at the
  // same depth; from x = 220 on, outside its 320 px.
  const Rendered& key = street()[2];
  syn::PinholeView shifted = key.view;
  shifted.K(0, 2) += 100;
  const Rendered other{shifted, syn::render(street_scene(), shifted, 1)};
  const DepthMap a = truth_map(key, "a");
  const DepthMap partner = truth_map(other, "partner");
  const cv::Mat mask = agreement_mask(a, partner, {});
  const cv::Rect inside(0, 0, kWidth - 100, kHeight);
  const cv::Rect outside(kWidth - 100, 0, 100, kHeight);
  EXPECT_EQ(count_where(mask(inside)), count_where(a.depth(inside) > 0));
  EXPECT_GT(count_where(mask(inside)), 0);
  EXPECT_EQ(count_where(mask(outside)), 0);
}

// ---------------------------------------------------------------------------
// weak_depths

// The street's middle view with exact depths: a neighbour 0.5 m to the side
// sees each point at an angle that shrinks with its distance; a pixel is
// narrow exactly where that angle is under the limit, whichever way it is
// computed. A small margin makes a pixel weak too; no neighbour judges none.
TEST(DenseStagesWeakDepths, NarrowWhereTheNeighbourSeesAtASmallAngle) {
  DepthMap map = truth_map(street()[2], "middle");
  map.margin = cv::Mat(map.depth.size(), CV_32F, cv::Scalar(0.5));
  map.margin(cv::Rect(0, 0, 40, 30)).setTo(0.01);
  const Eigen::Vector3d centre = -map.R.transpose() * map.t;
  const Eigen::Vector3d side = centre + 0.5 * map.R.row(0).transpose();
  ConsistencyOptions options;
  options.distinct_margin = 0.03;
  options.weak_triangulation_deg = 4;
  const cv::Mat weak = weak_depths(map, {side}, options);
  int narrow = 0, wide = 0, mismatched = 0;
  for (int y = 0; y < map.depth.rows; ++y) {
    for (int x = 0; x < map.depth.cols; ++x) {
      const float z = map.depth.at<float>(y, x);
      const bool is_weak = weak.at<uint8_t>(y, x) != 0;
      if (z <= 0) {
        mismatched += is_weak;
        continue;
      }
      const Eigen::Vector3d X = map.unproject(x, y, z);
      const double angle =
          std::acos((centre - X).normalized().dot((side - X).normalized())) *
          180 / M_PI;
      const bool expected = angle < 4 || (x < 40 && y < 30);
      // Exactly at the limit, rounding may go either way.
      if (std::abs(angle - 4) > 1e-6) mismatched += is_weak != expected;
      (angle < 4 ? narrow : wide) += 1;
    }
  }
  std::cout << narrow << " narrow, " << wide << " wide\n";
  EXPECT_GT(narrow, 1000);
  EXPECT_GT(wide, 10000);
  EXPECT_EQ(mismatched, 0);
  EXPECT_EQ(count_where(weak_depths(map, {}, options) !=
                        ((map.margin < 0.03) & (map.depth > 0))),
            0);
  options.weak_triangulation_deg = 0;
  options.distinct_margin = 0;
  EXPECT_EQ(count_where(weak_depths(map, {side}, options)), 0);
}

// ---------------------------------------------------------------------------
// judge_pair: free-space conflicts

// A floating board, 1.5 x 1 m, 3 m in front of the facade (y = 7, x 0.5 to
// 2, z 2.5 to 3.5): every street view sees it against the facade.
const syn::Quad& floater() {
  static const syn::Quad quad{{0.5, 7, 2.5}, {1.5, 0, 0}, {0, 0, 1}};
  return quad;
}

// A board sunk 2 m behind the facade (y = 12, x -1.5 to 0, z 2.5 to 3.5):
// no street view can see it; a map that has it measured past the facade.
const syn::Quad& sunken() {
  static const syn::Quad quad{{-1.5, 12, 2.5}, {1.5, 0, 0}, {0, 0, 1}};
  return quad;
}

// Draws `q` (a board of constant y) into `map`: where it lies in front of
// what the map has (a consistent floater, as a wrong match repeated across
// views makes), or, `through_surfaces`, wherever its ray meets it (a
// consistent depth measured past the surface). Returns the pixels it
// covers.
int inject_board(DepthMap* map, const syn::Quad& q, bool through_surfaces) {
  const Eigen::Vector3d centre = -map->R.transpose() * map->t;
  const Eigen::Matrix3d back = map->R.transpose() * map->K.inverse();
  int covered = 0;
  for (int y = 0; y < map->depth.rows; ++y) {
    for (int x = 0; x < map->depth.cols; ++x) {
      const Eigen::Vector3d ray = back * Eigen::Vector3d(x, y, 1);
      const double s = (q.corner.y() - centre.y()) / ray.y();
      const Eigen::Vector3d X = centre + s * ray;
      const double u = (X.x() - q.corner.x()) / q.edge_u.x();
      const double v = (X.z() - q.corner.z()) / q.edge_v.z();
      if (!(s > 0) || u < 0 || u > 1 || v < 0 || v > 1) continue;
      const float z = static_cast<float>((map->R * X + map->t).z());
      float& d = map->depth.at<float>(y, x);
      if (!through_surfaces && d > 0 && d <= z) continue;
      d = z;
      ++covered;
    }
  }
  return covered;
}

int inject_floater(DepthMap* map) {
  return inject_board(map, floater(), false);
}

TEST(DenseStagesFreeSpace, APartnerSeesThroughAFloaterInFrontOfTheFacade) {
  const auto& s = street();
  DepthMap a = truth_map(s[2], "a");
  const DepthMap clean = a;
  a.depth = clean.depth.clone();
  const int covered = inject_floater(&a);
  ASSERT_GT(covered, 1000);
  const cv::Mat on_floater = a.depth != clean.depth;
  const DepthMap partner = truth_map(s[3], "partner");
  const PairVerdict verdict = judge_pair(a, partner, {});
  ASSERT_EQ(verdict.sees_through.type(), CV_8U);
  // The partner's rays pass the board and meet the facade 3 m behind it.
  EXPECT_GE(count_where(verdict.sees_through & on_floater), 0.95 * covered);
  EXPECT_EQ(count_where(verdict.agrees & on_floater), 0);
  // The true surface: nearly never seen through (only where the nearest
  // pixel of a depth edge falls on the far side), and it still agrees.
  const cv::Mat surface = (a.depth > 0) & ~on_floater;
  EXPECT_LE(count_where(verdict.sees_through & surface),
            0.01 * count_where(surface));
  EXPECT_EQ(count_where(verdict.agrees & on_floater) +
                count_where(verdict.agrees & surface),
            count_where(agreement_mask(a, partner, {})));
  // Turned off, nothing is seen through.
  ConsistencyOptions off;
  off.free_space_margin = 0;
  EXPECT_EQ(count_where(judge_pair(a, partner, off).sees_through), 0);
}

TEST(DenseStagesFreeSpace, ADepthBehindTheSurfaceIsOccludedNotSeenThrough) {
  // A patch pushed 20 % behind the facade is hidden from the partner by
  // the facade itself: a nearer surface there is no conflict.
  const auto& s = street();
  DepthMap a = truth_map(s[2], "a");
  const cv::Rect patch(140, 40, 40, 40);  // on the facade
  cv::Mat behind = a.depth(patch);
  behind *= 1.2;
  const PairVerdict verdict = judge_pair(a, truth_map(s[3], "partner"), {});
  EXPECT_EQ(count_where(verdict.sees_through(patch)), 0);
  EXPECT_EQ(count_where(verdict.agrees(patch)), 0);
}

TEST(DenseStagesFreeSpace, ADepthPastTheSurfaceOvershootsThePartnersPoints) {
  // The other side of the same conflict: the partner's facade points lie on
  // the sunken board's rays, in front of it. Judging the partner against
  // the map marks the board's pixels of the map as overshooting.
  const auto& s = street();
  DepthMap a = truth_map(s[2], "a");
  a.depth = a.depth.clone();
  const int covered = inject_board(&a, sunken(), true);
  ASSERT_GT(covered, 500);
  const cv::Mat on_board = a.depth != s[2].image.depth;
  const DepthMap partner = truth_map(s[3], "partner");
  const PairVerdict verdict = judge_pair(partner, a, {});
  ASSERT_EQ(verdict.overshoots.size(), a.depth.size());
  EXPECT_GE(count_where(verdict.overshoots & on_board), 0.9 * covered);
  const cv::Mat surface = (a.depth > 0) & ~on_board;
  EXPECT_LE(count_where(verdict.overshoots & surface),
            0.01 * count_where(surface));
  // The partner's own pixels there are the ones a sees through.
  EXPECT_GT(count_where(verdict.sees_through), 0.5 * covered);
}

TEST(DenseStagesFreeSpace, AFloaterTwoMapsShareAgreesButIsOutvoted) {
  const auto& s = street();
  DepthMap a = truth_map(s[2], "a"), b = truth_map(s[3], "b");
  inject_floater(&a);
  inject_floater(&b);
  const cv::Mat on_floater = a.depth != s[2].image.depth;
  // The two that share the floater agree on it ...
  EXPECT_GE(count_where(judge_pair(a, b, {}).agrees & on_floater),
            0.9 * count_where(on_floater));
  // ... and each of three clean maps sees through it: fusable() keeps a
  // pixel only while more maps agree than see through it.
  int outvoted = 0, kept_surface = 0, surface = 0;
  std::vector<PairVerdict> verdicts;
  for (int other : {0, 1, 4})
    verdicts.push_back(judge_pair(a, truth_map(s[other], "c"), {}));
  verdicts.push_back(judge_pair(a, b, {}));
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      if (a.depth.at<float>(y, x) <= 0) continue;
      uint8_t agreed = 0, through = 0;
      for (const PairVerdict& v : verdicts) {
        agreed += v.agrees.at<uint8_t>(y, x) != 0;
        through += v.sees_through.at<uint8_t>(y, x) != 0;
      }
      if (on_floater.at<uint8_t>(y, x)) {
        outvoted += !fusable(agreed, through, 1);
      } else {
        ++surface;
        kept_surface += fusable(agreed, through, 1);
      }
    }
  }
  EXPECT_GE(outvoted, 0.95 * count_where(on_floater));
  EXPECT_GE(kept_surface, 0.95 * surface);
}

// ---------------------------------------------------------------------------
// sky_mask

// A picture whose top band is smooth sky over a textured facade, with a
// smooth plaque in the facade that does not reach the top.
cv::Mat sky_over_facade() {
  cv::Mat bgr(120, 160, CV_8UC3, cv::Scalar(230, 190, 150));
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> level(40, 200);
  for (int y = 40; y < bgr.rows; ++y)
    for (int x = 0; x < bgr.cols; ++x)
      bgr.at<cv::Vec3b>(y, x) = cv::Vec3b(level(rng), level(rng), level(rng));
  bgr(cv::Rect(60, 70, 30, 30)).setTo(cv::Scalar(120, 120, 120));
  return bgr;
}

TEST(DenseStagesSky, SmoothRegionJoinedToTheTopIsSky) {
  const cv::Mat sky = sky_mask(sky_over_facade(), 3.0);
  // The whole band is sky, down to the facade's edge: the rows whose 5 x 5
  // window reaches over the edge too (a 7 x 7 sweep window there would
  // match the facade's edge); no pixel of the facade is.
  EXPECT_EQ(cv::countNonZero(sky(cv::Rect(0, 0, 160, 40))), 160 * 40);
  EXPECT_EQ(cv::countNonZero(sky(cv::Rect(0, 40, 160, 80))), 0);
}

// The mask grows from the smooth region only into pixels of the sky's
// colour: a plain wall under the sky, a few grey levels brighter in one
// channel, keeps its pixels, although they are smooth too.
TEST(DenseStagesSky, TheMaskStopsAtAColourStep) {
  cv::Mat bgr = sky_over_facade();
  bgr(cv::Rect(0, 40, 160, 20)).setTo(cv::Scalar(230, 202, 150));
  const cv::Mat sky = sky_mask(bgr, 3.0);
  EXPECT_EQ(cv::countNonZero(sky(cv::Rect(0, 0, 160, 40))), 160 * 40);
  EXPECT_EQ(cv::countNonZero(sky(cv::Rect(0, 40, 160, 80))), 0);
}

// A sky whose colour drifts slowly (a gradient, one level every few
// pixels) is grown into all the same.
TEST(DenseStagesSky, AGradedSkyIsGrownToItsEdge) {
  cv::Mat bgr = sky_over_facade();
  for (int y = 0; y < 40; ++y)
    bgr(cv::Rect(0, y, 160, 1)).setTo(cv::Scalar(230 - y / 3, 190, 150));
  const cv::Mat sky = sky_mask(bgr, 3.0);
  EXPECT_EQ(cv::countNonZero(sky(cv::Rect(0, 0, 160, 40))), 160 * 40);
  EXPECT_EQ(cv::countNonZero(sky(cv::Rect(0, 40, 160, 80))), 0);
}

TEST(DenseStagesSky, SmoothRegionAwayFromTheTopIsNotSky) {
  const cv::Mat sky = sky_mask(sky_over_facade(), 3.0);
  EXPECT_EQ(cv::countNonZero(sky(cv::Rect(60, 70, 30, 30))), 0);
}

TEST(DenseStagesSky, TheTopOfAnUndistortedPictureIsUnderItsBlackBorder) {
  // Undistortion leaves a black border, deeper at the corners; its edge is
  // textured, yet the sky under it is still joined to the picture's top.
  cv::Mat bgr = sky_over_facade();
  for (int x = 0; x < bgr.cols; ++x) {
    const int depth = 3 + std::abs(x - bgr.cols / 2) / 10;
    bgr(cv::Rect(x, 0, 1, depth)).setTo(cv::Scalar(0, 0, 0));
  }
  bgr(cv::Rect(0, 0, 4, bgr.rows)).setTo(cv::Scalar(0, 0, 0));
  const cv::Mat sky = sky_mask(bgr, 3.0);
  EXPECT_EQ(cv::countNonZero(sky(cv::Rect(20, 14, 120, 23))), 120 * 23);
  EXPECT_EQ(cv::countNonZero(sky(cv::Rect(0, 43, 160, 77))), 0);
}

TEST(DenseStagesSky, ZeroTextureTurnsTheMaskOff) {
  EXPECT_EQ(cv::countNonZero(sky_mask(sky_over_facade(), 0.0)), 0);
}

TEST(DenseStagesSky, ANoisySkyIsKeptAsSurface) {
  cv::Mat bgr = sky_over_facade();
  cv::Mat noise(bgr.size(), CV_8UC3);
  cv::randu(noise, 0, 40);
  bgr += noise;
  EXPECT_LT(cv::countNonZero(sky_mask(bgr, 3.0)), 160 * 4);
}

// ---------------------------------------------------------------------------
// compare_depth_maps

TEST(DenseStagesCompare, ExactMapsOfDifferentViewsAgree) {
  // b is read at the nearest pixel centre, whose ray meets the slanted
  // facade and ground up to half a pixel away from the predicted point: at
  // f = 280 and the street's slants that is a few 1e-4 in depth at most.
  const auto& s = street();
  const DepthMap a = truth_map(s[1], "a");
  const DepthMap b = truth_map(s[3], "b");
  const DepthAgreement agreement = compare_depth_maps(a, b);
  EXPECT_GT(agreement.compared, 0.5 * kWidth * kHeight);
  EXPECT_LT(agreement.median_relative_difference, 3e-4);
}

TEST(DenseStagesCompare, ExactMapsOnTheSamePixelGridAgreeExactly) {
  // The same pose with the principal point 50 px further left: each pixel
  // lands on a pixel centre of the other, so nothing is interpolated.
  const Rendered& key = street()[2];
  syn::PinholeView shifted = key.view;
  shifted.K(0, 2) -= 50;
  const Rendered other{shifted, syn::render(street_scene(), shifted, 1)};
  const DepthAgreement agreement =
      compare_depth_maps(truth_map(key, "a"), truth_map(other, "b"));
  EXPECT_EQ(
      agreement.compared,
      count_where(key.image.depth(cv::Rect(50, 0, kWidth - 50, kHeight)) > 0));
  EXPECT_LT(agreement.median_relative_difference, 1e-6);
}

TEST(DenseStagesCompare, ScaledDepthsShowTheScale) {
  const auto& s = street();
  const DepthMap a = truth_map(s[1], "a");
  DepthMap b = truth_map(s[3], "b");
  b.depth *= 1.02;
  const DepthAgreement agreement = compare_depth_maps(a, b);
  EXPECT_GT(agreement.compared, 0.5 * kWidth * kHeight);
  EXPECT_NEAR(agreement.median_relative_difference, 0.02, 0.003);
}

TEST(DenseStagesCompare, NothingToCompareGivesZero) {
  DepthMap a = truth_map(street()[1], "a");
  const DepthMap b = truth_map(street()[3], "b");
  a.depth.setTo(0);
  const DepthAgreement agreement = compare_depth_maps(a, b);
  EXPECT_EQ(agreement.compared, 0);
  EXPECT_EQ(agreement.median_relative_difference, 0);
}

// ---------------------------------------------------------------------------
// VoxelCloud

TEST(DenseStagesVoxelCloud, RejectsNonPositiveSizes) {
  EXPECT_THROW(VoxelCloud(0), std::invalid_argument);
  EXPECT_THROW(VoxelCloud(-0.1), std::invalid_argument);
  EXPECT_THROW(VoxelCloud{std::numeric_limits<double>::quiet_NaN()},
               std::invalid_argument);
  EXPECT_NO_THROW(VoxelCloud(1e-3));
  EXPECT_EQ(VoxelCloud(0.25).voxel_size(), 0.25);
}

TEST(DenseStagesVoxelCloud, DuplicatesMergeDistinctVoxelsStay) {
  VoxelCloud cloud(0.1);
  const std::vector<Eigen::Vector3d> points = {{0.05, 0.05, 0.05},
                                               {0.15, 0.05, 0.05},
                                               {-0.05, 0.05, 0.05},
                                               {0.05, -0.05, 0.05},
                                               {0.05, 0.05, 1.05}};
  for (const auto& p : points) cloud.add(p, {1, 2, 3});
  EXPECT_EQ(cloud.size(), points.size());
  for (const auto& p : points) cloud.add(p, {1, 2, 3});
  EXPECT_EQ(cloud.size(), points.size());
  const auto out = cloud.points();
  ASSERT_EQ(out.size(), points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    EXPECT_FLOAT_EQ(out[i].x, static_cast<float>(points[i].x()));
    EXPECT_FLOAT_EQ(out[i].y, static_cast<float>(points[i].y()));
    EXPECT_FLOAT_EQ(out[i].z, static_cast<float>(points[i].z()));
    EXPECT_EQ(out[i].r, 1);
    EXPECT_EQ(out[i].g, 2);
    EXPECT_EQ(out[i].b, 3);
  }
  cloud.clear();
  EXPECT_EQ(cloud.size(), 0u);
  EXPECT_TRUE(cloud.points().empty());
}

// A point taken out leaves the voxel as if it had never been added; an
// emptied voxel is gone, the others keep their order, and removing from an
// empty voxel changes nothing.
TEST(DenseStagesVoxelCloud, RemoveUndoesAdd) {
  VoxelCloud cloud(1.0);
  cloud.add({0.2, 0.2, 0.2}, {10, 20, 30});
  cloud.add({5.5, 0.5, 0.5}, {1, 1, 1});
  cloud.add({0.6, 0.6, 0.6}, {30, 40, 50});
  cloud.add({9.5, 0.5, 0.5}, {2, 2, 2});
  EXPECT_EQ(cloud.size(), 3u);
  EXPECT_TRUE(cloud.remove({0.6, 0.6, 0.6}, {30, 40, 50}));
  EXPECT_TRUE(cloud.remove({5.5, 0.5, 0.5}, {1, 1, 1}));
  EXPECT_FALSE(cloud.remove({5.5, 0.5, 0.5}, {1, 1, 1}));
  EXPECT_FALSE(cloud.remove({-3.5, 0.5, 0.5}, {1, 1, 1}));
  ASSERT_EQ(cloud.size(), 2u);
  const auto out = cloud.points();
  ASSERT_EQ(out.size(), 2u);
  EXPECT_NEAR(out[0].x, 0.2, 1e-6);
  EXPECT_EQ(out[0].r, 10);
  EXPECT_EQ(out[0].b, 30);
  EXPECT_NEAR(out[1].x, 9.5, 1e-6);
  // Re-occupied, the voxel comes last.
  cloud.add({5.5, 0.5, 0.5}, {3, 3, 3});
  EXPECT_NEAR(cloud.points().back().x, 5.5, 1e-6);
  // Many removals compact the storage without changing what is seen.
  VoxelCloud many(1.0);
  for (int i = 0; i < 5000; ++i) many.add({i + 0.5, 0.5, 0.5}, {1, 2, 3});
  for (int i = 0; i < 5000; ++i)
    if (i % 3 != 0) {
      EXPECT_TRUE(many.remove({i + 0.5, 0.5, 0.5}, {1, 2, 3}));
    }
  const auto left = many.points();
  ASSERT_EQ(left.size(), many.size());
  ASSERT_EQ(left.size(), 1667u);
  for (size_t k = 0; k < left.size(); ++k)
    EXPECT_NEAR(left[k].x, 3.0 * k + 0.5, 1e-4);
}

// A voxel's normal is the unit mean of its samples' and its support their
// rounded mean; a sample's support can change in place, and removing every
// sample leaves nothing.
TEST(DenseStagesVoxelCloud, MeanNormalSupportAndScoreFollowTheSamples) {
  VoxelCloud cloud(1.0);
  const CloudSample a{{0.2, 0.2, 0.2}, {10, 20, 30}, {1, 0, 0}, 2, 0.8f};
  const CloudSample b{{0.4, 0.4, 0.4}, {10, 20, 30}, {0, 1, 0}, 5, 0.6f};
  cloud.add(a);
  cloud.add(b);
  auto points = cloud.points();
  ASSERT_EQ(points.size(), 1u);
  EXPECT_NEAR(points[0].nx, std::sqrt(0.5), 1e-6);
  EXPECT_NEAR(points[0].ny, std::sqrt(0.5), 1e-6);
  EXPECT_EQ(points[0].nz, 0);
  EXPECT_EQ(points[0].support, 4);  // (2 + 5) / 2, rounded
  EXPECT_EQ(points[0].score, 179);  // 0.7 * 255, rounded
  EXPECT_TRUE(cloud.change_support(a.xyz, 2, 9));
  EXPECT_EQ(cloud.points()[0].support, 7);
  EXPECT_FALSE(cloud.change_support({5.5, 0.5, 0.5}, 1, 2));
  CloudSample a_now = a;
  a_now.support = 9;
  EXPECT_TRUE(cloud.remove(a_now));
  points = cloud.points();
  ASSERT_EQ(points.size(), 1u);
  EXPECT_NEAR(points[0].ny, 1, 1e-6);
  EXPECT_EQ(points[0].support, 5);
  EXPECT_EQ(points[0].score, 153);  // 0.6 * 255
  EXPECT_TRUE(cloud.remove(b));
  EXPECT_EQ(cloud.size(), 0u);
  // Plain points carry neither.
  cloud.add({0.5, 0.5, 0.5}, {1, 1, 1});
  EXPECT_EQ(cloud.points()[0].support, 0);
  EXPECT_EQ(cloud.points()[0].score, 0);
  EXPECT_EQ(cloud.points()[0].nx, 0);
}

TEST(DenseStagesVoxelCloud, MeanPositionAndRoundedMeanColour) {
  VoxelCloud cloud(1.0);
  cloud.add({0.1, 0.2, 0.3}, {10, 200, 0});
  cloud.add({0.3, 0.4, 0.5}, {13, 201, 255});
  cloud.add({0.5, 0.6, 0.7}, {11, 201, 255});
  const auto out = cloud.points();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_NEAR(out[0].x, 0.3, 1e-6);
  EXPECT_NEAR(out[0].y, 0.4, 1e-6);
  EXPECT_NEAR(out[0].z, 0.5, 1e-6);
  EXPECT_EQ(out[0].r, 11);   // 34 / 3 = 11.33
  EXPECT_EQ(out[0].g, 201);  // 602 / 3 = 200.67
  EXPECT_EQ(out[0].b, 170);  // 510 / 3
  // Two colours: halves round up.
  VoxelCloud pair(1.0);
  pair.add({0.5, 0.5, 0.5}, {10, 0, 254});
  pair.add({0.5, 0.5, 0.5}, {13, 1, 255});
  const auto two = pair.points();
  ASSERT_EQ(two.size(), 1u);
  EXPECT_EQ(two[0].r, 12);  // 11.5
  EXPECT_EQ(two[0].g, 1);   // 0.5
  EXPECT_EQ(two[0].b, 255);
}

TEST(DenseStagesVoxelCloud, FirstSeenOrderIsDeterministic) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> coord(-3, 3);
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 2000; ++i) {
    const double x = coord(rng), y = coord(rng), z = coord(rng);
    points.emplace_back(x, y, z);
  }
  VoxelCloud a(0.5), b(0.5);
  for (const auto& p : points) a.add(p, {7, 8, 9});
  for (const auto& p : points) b.add(p, {7, 8, 9});
  const auto pa = a.points(), pb = b.points();
  ASSERT_EQ(pa.size(), pb.size());
  for (size_t i = 0; i < pa.size(); ++i) {
    EXPECT_EQ(pa[i].x, pb[i].x);
    EXPECT_EQ(pa[i].y, pb[i].y);
    EXPECT_EQ(pa[i].z, pb[i].z);
  }
  // The order is that of each voxel's first point.
  VoxelCloud ordered(1.0);
  ordered.add({5.5, 0.5, 0.5}, {1, 0, 0});
  ordered.add({-2.5, 0.5, 0.5}, {2, 0, 0});
  ordered.add({5.6, 0.6, 0.6}, {1, 0, 0});
  ordered.add({0.5, 0.5, 0.5}, {3, 0, 0});
  const auto out = ordered.points();
  ASSERT_EQ(out.size(), 3u);
  EXPECT_EQ(out[0].r, 1);
  EXPECT_EQ(out[1].r, 2);
  EXPECT_EQ(out[2].r, 3);
  EXPECT_NEAR(out[0].x, 5.55, 1e-6);
}

// The points of a box as points() filtered, in its order.
std::vector<ColoredPoint> filtered(const std::vector<ColoredPoint>& all,
                                   const Eigen::Vector2d& lo,
                                   const Eigen::Vector2d& hi) {
  std::vector<ColoredPoint> in;
  for (const ColoredPoint& p : all)
    if (p.x >= lo.x() && p.x < hi.x() && p.y >= lo.y() && p.y < hi.y())
      in.push_back(p);
  return in;
}

TEST(DenseStagesVoxelCloud, BlocksFollowTheChangesAndPointsInReadsABox) {
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> coord(-6, 6);
  std::vector<Eigen::Vector3d> samples;
  for (int i = 0; i < 6000; ++i)
    samples.emplace_back(coord(rng), coord(rng), coord(rng) / 4);
  VoxelCloud cloud(0.1);  // blocks of 1.6 m
  ASSERT_DOUBLE_EQ(cloud.block_edge(), 1.6);
  for (const auto& p : samples) cloud.add(p, {1, 2, 3});
  std::size_t listed = 0;
  for (const CloudBlock& block : cloud.blocks()) {
    EXPECT_GT(block.points, 0u);
    listed += block.points;
  }
  EXPECT_EQ(listed, cloud.size());
  // Any box, block edges or not: exactly points() inside it, in its order.
  for (const auto& [lo, hi] :
       {std::pair{Eigen::Vector2d(-1.6, 0), Eigen::Vector2d(1.6, 3.2)},
        std::pair{Eigen::Vector2d(-2.05, -5.3), Eigen::Vector2d(0.77, 4.1)},
        std::pair{Eigen::Vector2d(-100, -100), Eigen::Vector2d(100, 100)}}) {
    const auto want = filtered(cloud.points(), lo, hi);
    const auto got = cloud.points_in(lo, hi);
    ASSERT_EQ(got.size(), want.size());
    for (std::size_t i = 0; i < got.size(); ++i) {
      EXPECT_EQ(got[i].x, want[i].x);
      EXPECT_EQ(got[i].y, want[i].y);
      EXPECT_EQ(got[i].z, want[i].z);
    }
  }
  // After a mark, only the blocks edited carry a later stamp; a block
  // emptied is listed with no point.
  const std::uint64_t seen = cloud.mark();
  cloud.add({0.05, 0.05, 0}, {1, 2, 3});  // block (0, 0)
  std::size_t emptied = 0;
  for (const auto& p : samples)
    if (p.x() >= 3.2 && p.x() < 4.8 && p.y() >= 3.2 && p.y() < 4.8) {
      ASSERT_TRUE(cloud.remove(p, {1, 2, 3}));  // block (2, 2)
      ++emptied;
    }
  ASSERT_GT(emptied, 0u);
  for (const CloudBlock& block : cloud.blocks()) {
    const bool added = block.ix == 0 && block.iy == 0;
    const bool emptied = block.ix == 2 && block.iy == 2;
    EXPECT_EQ(block.points == 0, emptied);
    EXPECT_EQ(block.changed > seen, added || emptied)
        << block.ix << " " << block.iy;
  }
  // Removals far past half the voxels compact the cloud: the blocks still
  // read what points() holds.
  for (const auto& p : samples)
    if (p.x() < 2) cloud.remove(p, {1, 2, 3});
  const Eigen::Vector2d lo(-7, -7), hi(7, 7);
  EXPECT_EQ(cloud.points_in(lo, hi).size(), cloud.points().size());
  // A cloud made later, or cleared, is all later stamps.
  const std::uint64_t before = cloud.mark();
  VoxelCloud other(0.1);
  other.add({0, 0, 0}, {1, 2, 3});
  cloud.clear();
  cloud.add({0, 0, 0}, {1, 2, 3});
  EXPECT_GT(other.blocks().front().changed, before);
  EXPECT_GT(cloud.blocks().front().changed, before);
}

// ---------------------------------------------------------------------------
// render_points

class DenseStagesRenderPoints : public ::testing::Test {
 protected:
  // f = 100, principal point (50, 40), at the origin looking down +z.
  Eigen::Matrix3d K() const {
    Eigen::Matrix3d k;
    k << 100, 0, 50, 0, 100, 40, 0, 0, 1;
    return k;
  }
  PointRendering draw(const std::vector<ColoredPoint>& points,
                      int radius) const {
    return render_points(points, K(), Eigen::Matrix3d::Identity(),
                         Eigen::Vector3d::Zero(), size_, radius);
  }
  const cv::Size size_{101, 81};
};

TEST_F(DenseStagesRenderPoints, OnePointLandsOnItsPixelWithItsColour) {
  // (0.1, 0.2, 2) -> (50 + 100 * 0.05, 40 + 100 * 0.1) = (55, 50).
  const PointRendering out = draw({{0.1f, 0.2f, 2.0f, 10, 20, 30}}, 0);
  ASSERT_EQ(out.bgr.size(), size_);
  ASSERT_EQ(out.bgr.type(), CV_8UC3);
  ASSERT_EQ(out.depth.type(), CV_32F);
  EXPECT_EQ(count_where(out.depth > 0), 1);
  EXPECT_FLOAT_EQ(out.depth.at<float>(50, 55), 2.0f);
  EXPECT_EQ(out.bgr.at<cv::Vec3b>(50, 55), cv::Vec3b(30, 20, 10));
  cv::Mat grey;
  cv::extractChannel(out.bgr, grey, 0);
  EXPECT_EQ(count_where(grey), 1);
  // The pose applies: x_cam = R x_world + t.
  const PointRendering moved = render_points(
      {{1.1f, 0.2f, 2.0f, 10, 20, 30}}, K(), Eigen::Matrix3d::Identity(),
      Eigen::Vector3d(-1, 0, 0), size_, 0);
  EXPECT_FLOAT_EQ(moved.depth.at<float>(50, 55), 2.0f);
}

TEST_F(DenseStagesRenderPoints, NearerPointWinsInEitherOrder) {
  const ColoredPoint near{0.1f, 0.2f, 2.0f, 255, 0, 0};
  const ColoredPoint far{0.2f, 0.4f, 4.0f, 0, 255, 0};  // same pixel
  for (const auto& points : {std::vector<ColoredPoint>{near, far},
                             std::vector<ColoredPoint>{far, near}}) {
    const PointRendering out = draw(points, 0);
    EXPECT_EQ(count_where(out.depth > 0), 1);
    EXPECT_FLOAT_EQ(out.depth.at<float>(50, 55), 2.0f);
    EXPECT_EQ(out.bgr.at<cv::Vec3b>(50, 55), cv::Vec3b(0, 0, 255));
  }
}

// orbit_view: a cube of points seen from north-east and above is centred,
// fits the frame (but for corners beyond the 95 % radius), +z up.
TEST(DenseStagesOrbitView, FramesTheCloudUprightFromTheAskedDirection) {
  std::vector<ColoredPoint> cube;
  for (int i = 0; i <= 10; ++i)
    for (int j = 0; j <= 10; ++j)
      for (int k = 0; k <= 10; ++k)
        cube.push_back({10.0f + i * 0.2f, -5.0f + j * 0.2f, 2.0f + k * 0.2f,
                        200, 100, 50});
  cube.push_back({1000, 1000, 1000, 255, 255, 255});  // a stray point
  const cv::Size size(640, 480);
  const PinholeView view = orbit_view(cube, 45, 30, size);
  // The camera sits north-east of and above the cube's median (11, -4, 3).
  const Eigen::Vector3d C = -view.R.transpose() * view.t;
  EXPECT_GT(C.x(), 11);
  EXPECT_GT(C.y(), -4);
  EXPECT_GT(C.z(), 3);
  EXPECT_NEAR(std::atan2(C.x() - 11, C.y() + 4), M_PI / 4, 1e-9);
  // The median projects to the image centre; 95 % of the points are inside.
  auto project = [&](const Eigen::Vector3d& X) {
    const Eigen::Vector3d h = view.K * (view.R * X + view.t);
    return Eigen::Vector2d(h.x() / h.z(), h.y() / h.z());
  };
  EXPECT_NEAR(project({11, -4, 3}).x(), 320, 1e-6);
  EXPECT_NEAR(project({11, -4, 3}).y(), 240, 1e-6);
  size_t inside = 0;
  for (size_t i = 0; i + 1 < cube.size(); ++i) {
    const Eigen::Vector2d uv = project({cube[i].x, cube[i].y, cube[i].z});
    inside += uv.x() >= 0 && uv.x() < 640 && uv.y() >= 0 && uv.y() < 480;
  }
  EXPECT_GE(inside, 0.95 * (cube.size() - 1));
  // +z is up in the image: a higher point lands on a smaller row.
  EXPECT_LT(project({11, -4, 4}).y(), project({11, -4, 3}).y());
  const PointRendering out = render_points(cube, view.K, view.R, view.t, size);
  EXPECT_GT(count_where(out.depth > 0), 1000);
  EXPECT_THROW(orbit_view({}, 0, 30, size), std::invalid_argument);
}

TEST_F(DenseStagesRenderPoints, PointsBehindOrOutsideAreSkipped) {
  const PointRendering out = draw({{0.1f, 0.2f, -2.0f, 255, 255, 255},
                                   {0.0f, 0.0f, 0.0f, 255, 255, 255},
                                   {5.0f, 0.0f, 1.0f, 255, 255, 255},
                                   {0.0f, -5.0f, 1.0f, 255, 255, 255}},
                                  1);
  EXPECT_EQ(count_where(out.depth), 0);
  EXPECT_EQ(count_where(out.bgr.reshape(1)), 0);
}

TEST_F(DenseStagesRenderPoints, RadiusOneCoversThreeByThree) {
  const PointRendering out = draw({{0.1f, 0.2f, 2.0f, 10, 20, 30}}, 1);
  EXPECT_EQ(count_where(out.depth > 0), 9);
  EXPECT_EQ(count_where(out.depth(cv::Rect(54, 49, 3, 3)) > 0), 9);
  EXPECT_EQ(out.bgr.at<cv::Vec3b>(51, 56), cv::Vec3b(30, 20, 10));
  // At the corner the splat is clipped: (0, 0) covers 2 x 2 pixels.
  const PointRendering corner = draw({{-0.5f, -0.4f, 1.0f, 1, 1, 1}}, 1);
  EXPECT_EQ(count_where(corner.depth > 0), 4);
  EXPECT_EQ(count_where(corner.depth(cv::Rect(0, 0, 2, 2)) > 0), 4);
}

// ---------------------------------------------------------------------------
// DenseReconstruction on a hand-built sparse model

// Every track entry names a keypoint that names the point back.
void expect_consistent(const Model& model) {
  for (const ModelPoint& point : model.points) {
    for (const auto& [image, keypoint] : point.track) {
      ASSERT_GE(image, 0);
      ASSERT_LT(image, static_cast<int>(model.images.size()));
      const ModelImage& im = model.images[image];
      ASSERT_EQ(im.keypoints.size(), im.point_ids.size());
      ASSERT_LT(keypoint, static_cast<int>(im.point_ids.size()));
      EXPECT_EQ(im.point_ids[keypoint], point.id);
    }
  }
}

// The street photos as PNG bytes, by id.
const std::map<std::string, std::string>& street_pngs() {
  static const std::map<std::string, std::string> pngs = [] {
    std::map<std::string, std::string> result;
    for (int i = 0; i < kViews; ++i) {
      std::vector<uchar> bytes;
      if (!cv::imencode(".png", street()[i].image.bgr, bytes))
        throw std::runtime_error("PNG encoding failed");
      result[view_id(i)] = std::string(bytes.begin(), bytes.end());
    }
    return result;
  }();
  return pngs;
}

ImageSource street_images() {
  return [](const std::string& id) {
    const auto& pngs = street_pngs();
    auto it = pngs.find(id);
    if (it == pngs.end()) throw std::invalid_argument("no photo " + id);
    return it->second;
  };
}

// At 320 x 240, with planes three pixels apart (sub-plane refinement does the
// rest): the bookkeeping is under test here, and five sweeps stay fast.
DenseOptions small_dense_options() {
  DenseOptions options;
  options.long_side = kWidth;
  options.sweep.plane_step_px = 3;
  options.sweep.min_planes = 32;
  // Every registered view a key view: what it sees decides nothing here.
  options.redundant_share = 0;
  options.new_coverage_share = 0;
  return options;
}

// Distance from X to the parallelogram (an upper bound when its edges are
// not perpendicular; exact for the street's rectangles).
double distance_to_quad(const syn::Quad& quad, const Eigen::Vector3d& X) {
  Eigen::Matrix<double, 3, 2> A;
  A << quad.edge_u, quad.edge_v;
  Eigen::Vector2d st =
      (A.transpose() * A).ldlt().solve(A.transpose() * (X - quad.corner));
  st = st.cwiseMax(0.0).cwiseMin(1.0);
  return (quad.corner + A * st - X).norm();
}

double distance_to_site(const Eigen::Vector3d& X) {
  double best = std::numeric_limits<double>::infinity();
  for (const syn::Quad& quad : street_scene().quads)
    best = std::min(best, distance_to_quad(quad, X));
  return best;
}

std::pair<double, Eigen::Vector3d> nearest_surface(const Eigen::Vector3d& X,
                                                   const Eigen::Vector3d& eye) {
  const syn::Quad* nearest = nullptr;
  double best = std::numeric_limits<double>::infinity();
  for (const syn::Quad& quad : street_scene().quads) {
    const double d = distance_to_quad(quad, X);
    if (d < best) best = d, nearest = &quad;
  }
  Eigen::Vector3d normal = nearest->edge_u.cross(nearest->edge_v).normalized();
  if (normal.dot(eye - X) < 0) normal = -normal;
  return {best, normal};
}

std::set<std::string> as_set(const std::vector<std::string>& ids) {
  return {ids.begin(), ids.end()};
}

TEST(DenseStagesReconstruction, GrowsIncrementallyAndWithdraws) {
  const SparseTruth truth = sparse_truth(street(), 300, 17);
  const Model first3 = build_model(street(), truth, {0, 1, 2});
  const Model all5 = build_model(street(), truth, {0, 1, 2, 3, 4});
  const Model without1 = build_model(street(), truth, {0, 2, 3, 4});
  expect_consistent(first3);
  expect_consistent(all5);
  expect_consistent(without1);
  ASSERT_GE(first3.points.size(), 150u);
  const ImageSource images = street_images();

  DenseReconstruction dense(small_dense_options());
  EXPECT_TRUE(dense.points().empty());
  EXPECT_EQ(dense.voxel_size(), 0);
  EXPECT_EQ(dense.raw_depth_map("view0"), nullptr);

  std::vector<std::string> told;
  const DenseUpdate u1 = dense.update(
      first3, images, [&](const std::string& id) { told.push_back(id); });
  EXPECT_EQ(as_set(u1.new_depth_maps),
            (std::set<std::string>{"view0", "view1", "view2"}));
  EXPECT_EQ(u1.new_depth_maps.size(), 3u);
  EXPECT_EQ(as_set(told), as_set(u1.new_depth_maps));
  EXPECT_TRUE(u1.skipped.empty());
  EXPECT_FALSE(u1.refused);
  const size_t points1 = dense.points().size();
  EXPECT_GT(points1, 1000u);
  EXPECT_EQ(u1.points, points1);
  // 1.5 pixel footprints at the median depth (about 9 m at f = 280).
  EXPECT_GT(dense.voxel_size(), 1.5 * 7 / kFocal);
  EXPECT_LT(dense.voxel_size(), 1.5 * 11 / kFocal);
  for (const char* id : {"view0", "view1", "view2"}) {
    const DepthMap* map = dense.raw_depth_map(id);
    ASSERT_NE(map, nullptr) << id;
    EXPECT_EQ(map->id, id);
    EXPECT_EQ(map->depth.size(), cv::Size(kWidth, kHeight));
    EXPECT_GT(map->coverage(), 0.3) << id;
  }
  EXPECT_EQ(dense.raw_depth_map("view3"), nullptr);

  // The same model again: nothing to sweep, nothing new to fuse.
  told.clear();
  const DenseUpdate u2 = dense.update(
      first3, images, [&](const std::string& id) { told.push_back(id); });
  EXPECT_TRUE(u2.new_depth_maps.empty());
  EXPECT_TRUE(told.empty());
  EXPECT_FALSE(u2.refused);
  EXPECT_EQ(u2.points, points1);
  EXPECT_EQ(dense.points().size(), points1);

  // Two more views: two more maps, more points.
  const DenseUpdate u3 = dense.update(all5, images);
  EXPECT_EQ(u3.new_depth_maps, (std::vector<std::string>{"view3", "view4"}));
  EXPECT_FALSE(u3.refused);
  const std::vector<ColoredPoint> cloud5 = dense.points();
  EXPECT_GT(cloud5.size(), points1);
  EXPECT_EQ(u3.points, cloud5.size());

  // The filtered maps are the raw ones with pixels taken away.
  const std::vector<DepthMap> filtered = dense.filtered_depth_maps();
  ASSERT_EQ(filtered.size(), 5u);
  std::set<std::string> filtered_ids;
  for (const DepthMap& f : filtered) {
    filtered_ids.insert(f.id);
    const DepthMap* raw = dense.raw_depth_map(f.id);
    ASSERT_NE(raw, nullptr) << f.id;
    ASSERT_EQ(f.depth.size(), raw->depth.size());
    const cv::Mat kept = f.depth > 0;
    EXPECT_EQ(count_where((raw->depth != f.depth) & kept), 0) << f.id;
    EXPECT_EQ(count_where(kept & (raw->depth <= 0)), 0) << f.id;
    EXPECT_GT(count_where(kept), 0.2 * count_where(raw->depth > 0)) << f.id;
    EXPECT_LE(count_where(kept), count_where(raw->depth > 0)) << f.id;
    EXPECT_EQ(f.R, raw->R);
    EXPECT_EQ(f.t, raw->t);
  }
  EXPECT_EQ(filtered_ids, (std::set<std::string>{"view0", "view1", "view2",
                                                 "view3", "view4"}));

  // The fused points lie on the street's surfaces.
  const Eigen::Vector3d centre = street()[2].view.centre();
  int near = 0;
  for (const ColoredPoint& p : cloud5) {
    const Eigen::Vector3d X(p.x, p.y, p.z);
    if (distance_to_site(X) < 0.02 * (X - centre).norm()) ++near;
  }
  EXPECT_GE(near, 0.95 * cloud5.size());

  // Withdrawing view1: its map goes and the cloud is rebuilt without it.
  const DenseUpdate u4 = dense.update(without1, images);
  EXPECT_TRUE(u4.new_depth_maps.empty());
  EXPECT_TRUE(u4.refused);
  EXPECT_EQ(dense.raw_depth_map("view1"), nullptr);
  EXPECT_NE(dense.raw_depth_map("view2"), nullptr);
  const size_t points4 = dense.points().size();
  EXPECT_GT(points4, 0u);
  EXPECT_NE(points4, cloud5.size());
  EXPECT_EQ(u4.points, points4);
  EXPECT_EQ(dense.filtered_depth_maps().size(), 4u);
}

// Disabled: fails today. A withdrawn capture's map keeps vouching for the
// pixels of the maps it agreed with (Entry::agreed is never recomputed when
// a map is dropped), so after withdrawing view1 some 1 400 to 3 500 depths
// of each remaining map agree with no remaining map, against "a depth
// survives only when another map agrees". Enable once
// DenseReconstruction::update re-filters the remaining maps after
// drop_withdrawn().
TEST(DenseStagesReconstruction, WithdrawnMapNoLongerVouches) {
  const SparseTruth truth = sparse_truth(street(), 300, 17);
  const ImageSource images = street_images();
  DenseReconstruction dense(small_dense_options());
  dense.update(build_model(street(), truth, {0, 1, 2, 3, 4}), images);
  dense.update(build_model(street(), truth, {0, 2, 3, 4}), images);
  const std::vector<DepthMap> maps = dense.filtered_depth_maps();
  ASSERT_EQ(maps.size(), 4u);
  for (const DepthMap& map : maps) {
    cv::Mat vouched = cv::Mat::zeros(map.depth.size(), CV_8U);
    for (const DepthMap& other : maps) {
      if (other.id == map.id) continue;
      vouched |= agreement_mask(map, *dense.raw_depth_map(other.id), {});
    }
    EXPECT_EQ(count_where((map.depth > 0) & (vouched == 0)), 0) << map.id;
  }
}

// With min_agreeing_maps 2, a depth is kept only where two other maps agree
// with it: each pair of maps is counted once, however often the filter
// meets it (the five views are swept in one update, so each pair is met
// from both sides).
TEST(DenseStagesReconstruction, ADepthTwoMapsMustAgreeWithIsKeptOnlyThen) {
  const SparseTruth truth = sparse_truth(street(), 300, 17);
  const ImageSource images = street_images();
  const Model all5 = build_model(street(), truth, {0, 1, 2, 3, 4});
  DenseOptions one_options = small_dense_options();
  DenseOptions two_options = one_options;
  two_options.consistency.min_agreeing_maps = 2;
  DenseReconstruction one(one_options), two(two_options);
  one.update(all5, images);
  two.update(all5, images);
  const std::vector<DepthMap> kept_one = one.filtered_depth_maps();
  const std::vector<DepthMap> kept_two = two.filtered_depth_maps();
  ASSERT_EQ(kept_two.size(), 5u);
  for (size_t m = 0; m < kept_two.size(); ++m) {
    const DepthMap& map = kept_two[m];
    cv::Mat vouching = cv::Mat::zeros(map.depth.size(), CV_8U);
    for (const DepthMap& other : kept_two) {
      if (other.id == map.id) continue;
      cv::add(vouching, 1, vouching,
              agreement_mask(map, *two.raw_depth_map(other.id), {}));
    }
    const int kept = count_where(map.depth > 0);
    EXPECT_GT(kept, 0) << map.id;
    // Partners are the best-connected four: all four others here.
    EXPECT_EQ(count_where((map.depth > 0) & (vouching < 2)), 0) << map.id;
    EXPECT_EQ(count_where((map.depth <= 0) & (vouching >= 2) &
                          (two.raw_depth_map(map.id)->depth > 0)),
              0)
        << map.id;
    EXPECT_LT(kept, count_where(kept_one[m].depth > 0)) << map.id;
  }
  EXPECT_LT(two.points().size(), one.points().size());
}

// Each fused point carries its surface's normal, facing the cameras, and
// its support: how many of the maps measured it, which grows as maps that
// see it are added and falls as they are withdrawn.
TEST(DenseStagesReconstruction, FusedPointsCarryNormalAndSupport) {
  const SparseTruth truth = sparse_truth(street(), 300, 17);
  const ImageSource images = street_images();
  const Model first2 = build_model(street(), truth, {1, 2});
  const Model all5 = build_model(street(), truth, {0, 1, 2, 3, 4});
  DenseReconstruction dense(small_dense_options());
  dense.update(first2, images);
  auto supports = [&] {
    std::map<int, int> count;
    for (const ColoredPoint& p : dense.points()) ++count[p.support];
    return count;
  };
  const auto two = supports();
  ASSERT_FALSE(two.empty());
  EXPECT_GE(two.begin()->first, 1);
  EXPECT_LE(two.rbegin()->first, 2);
  dense.update(all5, images);
  const std::vector<ColoredPoint> cloud = dense.points();
  const auto five = supports();
  EXPECT_LE(five.rbegin()->first, 5);
  int confident = 0, normals = 0, true_normals = 0, on_site = 0;
  const Eigen::Vector3d centre = street()[2].view.centre();
  for (const ColoredPoint& p : cloud) {
    const Eigen::Vector3d X(p.x, p.y, p.z);
    const Eigen::Vector3d n(p.nx, p.ny, p.nz);
    confident += p.support >= kConfidentSupport;
    if (n.norm() == 0) continue;
    EXPECT_NEAR(n.norm(), 1, 1e-4);
    ++normals;
    // The nearest surface's normal, turned toward the cameras.
    const auto [distance, truth_n] = nearest_surface(X, centre);
    if (distance > 0.02 * (X - centre).norm()) continue;
    ++on_site;
    true_normals += n.dot(truth_n) > std::cos(15 * M_PI / 180);
  }
  std::cout << cloud.size() << " points, " << normals << " with a normal, "
            << true_normals << " of " << on_site
            << " on the surfaces within 15 degrees, " << confident
            << " confident\n";
  EXPECT_GE(normals, 0.95 * cloud.size());
  // Measured: 71 % (swept maps at 320 x 240, where the depth noise of a
  // facade seen head-on is a large share of a 13-pixel window's extent).
  EXPECT_GE(true_normals, 0.65 * on_site);
  // Most of the street is seen by three maps or more once all five are in.
  EXPECT_GE(confident, 0.5 * cloud.size());
  // Withdrawing three views leaves no point supported by more than two.
  dense.update(first2, images);
  EXPECT_LE(supports().rbegin()->first, 2);
}

// The swept maps of `dense`, a board drawn into those of `views`
// (inject_board); with a `margin`, the board's pixels get it as their
// margin over the runner-up (as an ambiguous match would: a window across
// a depth edge, or a repeated texture, beats other depths by little).
std::vector<std::string> maps_with_board(
    const DenseReconstruction& dense, const std::set<std::string>& views,
    const syn::Quad& board, bool through_surfaces,
    std::optional<float> margin = std::nullopt) {
  std::vector<std::string> blobs;
  for (const std::string& id : dense.depth_map_ids()) {
    std::string blob = dense.serialize_depth_map(id);
    if (views.count(id)) {
      SweptDepthMap swept = decode_depth_map(blob);
      const cv::Mat before = swept.map.depth.clone();
      swept.map.depth = swept.map.depth.clone();
      EXPECT_GT(inject_board(&swept.map, board, through_surfaces), 500) << id;
      if (margin) {
        swept.map.margin = swept.map.margin.clone();
        swept.map.margin.setTo(*margin, swept.map.depth != before);
      }
      blob = encode_depth_map(swept);
    }
    blobs.push_back(blob);
  }
  return blobs;
}
std::vector<std::string> maps_with_floater(const DenseReconstruction& dense,
                                           const std::set<std::string>& views) {
  return maps_with_board(dense, views, floater(), false);
}

struct CloudCount {
  int on_floater = 0;  // within 5 cm of the board
  int on_site = 0;     // on the street's surfaces (2 % of the distance)
};
CloudCount count_cloud(const std::vector<ColoredPoint>& cloud,
                       const syn::Quad& board = floater()) {
  const Eigen::Vector3d centre = street()[2].view.centre();
  CloudCount count;
  for (const ColoredPoint& p : cloud) {
    const Eigen::Vector3d X(p.x, p.y, p.z);
    count.on_floater += distance_to_quad(board, X) < 0.05;
    count.on_site += distance_to_site(X) < 0.02 * (X - centre).norm();
  }
  return count;
}

// The five street views' model, and their maps swept.
struct FiveSwept {
  Model model;
  DenseReconstruction dense;
};
FiveSwept five_swept() {
  const SparseTruth truth = sparse_truth(street(), 300, 17);
  FiveSwept five{build_model(street(), truth, {0, 1, 2, 3, 4}),
                 DenseReconstruction(small_dense_options())};
  five.dense.update(five.model, street_images());
  return five;
}

// The five street maps swept, `board` drawn into views 1 and 3
// (inject_board), and restored with and without the free-space check: the
// cloud counted clean, unchecked and checked.
struct BoardClouds {
  CloudCount clean, unchecked, checked;
};
BoardClouds fuse_with_board(const syn::Quad& board, bool through_surfaces) {
  const ImageSource images = street_images();
  const auto [all5, swept] = five_swept();
  const std::vector<std::string> blobs =
      maps_with_board(swept, {"view1", "view3"}, board, through_surfaces);
  DenseOptions no_check = small_dense_options();
  no_check.consistency.free_space_margin = 0;
  DenseReconstruction unchecked(no_check), checked(small_dense_options());
  unchecked.restore_depth_maps(blobs, all5, images);
  checked.restore_depth_maps(blobs, all5, images);
  return {count_cloud(swept.points(), board),
          count_cloud(unchecked.points(), board),
          count_cloud(checked.points(), board)};
}

// A board floating in front of the facade in two of the five maps (the two
// agree on it) is seen through by the other three: the free-space check
// keeps it out of the cloud, and keeps the street's surfaces in.
TEST(DenseStagesReconstruction, AFloaterOtherMapsSeeThroughIsNotFused) {
  const auto [clean, with_floater, filtered] =
      fuse_with_board(floater(), false);
  // Without the check the floater is fused: the two maps vouch for it.
  EXPECT_GT(with_floater.on_floater, 300);
  EXPECT_LE(filtered.on_floater, 0.02 * with_floater.on_floater);
  EXPECT_LE(clean.on_floater, 0.02 * with_floater.on_floater);
  // The surfaces behind it are still measured from the other maps.
  EXPECT_GE(filtered.on_site, 0.95 * clean.on_site);
}

// The same board sunk behind the facade in two maps: the other three see
// the facade in front of it on its rays, and it is not fused.
TEST(DenseStagesReconstruction, ADepthPastTheSurfaceOtherMapsSeeIsNotFused) {
  const auto [clean, with_board, filtered] = fuse_with_board(sunken(), true);
  EXPECT_EQ(clean.on_floater, 0);
  EXPECT_GT(with_board.on_floater, 300);
  EXPECT_LE(filtered.on_floater, 0.02 * with_board.on_floater);
  EXPECT_GE(filtered.on_site, 0.95 * clean.on_site);
}

// Incrementally: the floater is fused while only the two maps that share it
// are there, and taken out of the cloud when later maps see through it.
TEST(DenseStagesReconstruction, AFusedFloaterLeavesWhenLaterMapsSeeThrough) {
  const SparseTruth truth = sparse_truth(street(), 300, 17);
  const ImageSource images = street_images();
  const Model two = build_model(street(), truth, {1, 3});
  DenseReconstruction swept(small_dense_options());
  swept.update(two, images);
  DenseReconstruction dense(small_dense_options());
  dense.restore_depth_maps(maps_with_floater(swept, {"view1", "view3"}), two,
                           images);
  const CloudCount before = count_cloud(dense.points());
  EXPECT_GT(before.on_floater, 300);
  const DenseUpdate later =
      dense.update(build_model(street(), truth, {1, 3, 0, 2, 4}), images);
  EXPECT_EQ(later.new_depth_maps.size(), 3u);
  EXPECT_FALSE(later.refused);  // taken out pixel by pixel, not rebuilt
  const CloudCount after = count_cloud(dense.points());
  EXPECT_LE(after.on_floater, 0.02 * before.on_floater);
  EXPECT_EQ(later.points, dense.points().size());
  EXPECT_GT(after.on_site, before.on_site);
}

// Two maps that agree on an ambiguous floater (free space off: nothing
// else stands in its way) fuse it; asked for a distinct match or a second
// agreeing map, the cloud leaves it out and keeps the street, which the
// five maps measure distinctly or agree on thrice.
TEST(DenseStagesReconstruction, AnAmbiguousFloaterTwoMapsShareIsNotFused) {
  const ImageSource images = street_images();
  const auto [all5, swept] = five_swept();
  const std::vector<std::string> blobs =
      maps_with_board(swept, {"view1", "view3"}, floater(), false, 0.01f);
  DenseOptions lenient = small_dense_options();
  lenient.consistency.free_space_margin = 0;
  lenient.consistency.distinct_margin = 0;
  DenseOptions distinct = lenient;
  distinct.consistency.distinct_margin = 0.05;
  DenseReconstruction fused(lenient), checked(distinct);
  fused.restore_depth_maps(blobs, all5, images);
  checked.restore_depth_maps(blobs, all5, images);
  const CloudCount before = count_cloud(fused.points());
  const CloudCount after = count_cloud(checked.points());
  std::cout << "floater " << before.on_floater << " -> " << after.on_floater
            << ", street " << before.on_site << " -> " << after.on_site << "\n";
  EXPECT_GT(before.on_floater, 300);
  EXPECT_LE(after.on_floater, 0.02 * before.on_floater);
  EXPECT_GE(after.on_site, 0.9 * before.on_site);
}

// A second photo from view 2's place (a scout standing still) sees only
// what the maps of views 1-3, which see the same street, measure already
// (each of its points observed by 3 of them): no key view, no sweep,
// judged once; withdrawing view 2 leaves 2 observers, makes it a candidate
// again, and it is swept then.
// Views 1-3 and "again": view 2 photographed a second time.
Model model_with_view2_again(const SparseTruth& truth) {
  Model model = build_model(street(), truth, {1, 2, 3});
  ModelImage again = model.images[1];  // view2
  again.id = "again";
  const int index = static_cast<int>(model.images.size());
  for (ModelPoint& point : model.points) {
    for (size_t t = 0, n = point.track.size(); t < n; ++t)
      if (point.track[t].first == 1)
        point.track.emplace_back(index, point.track[t].second);
  }
  model.images.push_back(again);
  return model;
}

ImageSource view2_again_images() {
  const ImageSource views = street_images();
  return [views](const std::string& id) {
    return views(id == "again" ? "view2" : id);
  };
}

TEST(DenseStagesReconstruction, AViewWhosePictureTheMapsMeasureIsNoKeyView) {
  const SparseTruth truth = sparse_truth(street(), 300, 17);
  const Model model = model_with_view2_again(truth);
  DenseOptions options = small_dense_options();
  options.new_coverage_share = 0.8;  // off by default
  DenseReconstruction dense(options);
  const DenseUpdate update = dense.update(model, view2_again_images());
  // The street's views converge on one facade: once the maps of views 1
  // and 2 measure it (two maps, so that their depths can agree), view 3
  // and the second photo of view 2 bring nothing.
  EXPECT_EQ(update.new_depth_maps,
            (std::vector<std::string>{"view1", "view2"}));
  EXPECT_EQ(update.covered, (std::vector<std::string>{"view3", "again"}));
  EXPECT_GT(update.points, 0u);
}

TEST(DenseStagesReconstruction, AViewTheMapsMeasureAlreadyIsNoKeyView) {
  const SparseTruth truth = sparse_truth(street(), 300, 17);
  const Model model = model_with_view2_again(truth);
  const ImageSource images = view2_again_images();
  DenseOptions options = small_dense_options();
  options.redundant_share = DenseOptions{}.redundant_share;
  DenseReconstruction dense(options);
  const DenseUpdate u1 = dense.update(model, images);
  EXPECT_EQ(u1.new_depth_maps.size(), 3u);
  EXPECT_EQ(u1.covered, std::vector<std::string>{"again"});
  EXPECT_EQ(dense.raw_depth_map("again"), nullptr);
  const DenseUpdate u2 = dense.update(model, images);
  EXPECT_TRUE(u2.new_depth_maps.empty());
  EXPECT_TRUE(u2.covered.empty());

  Model without2 = model;
  without2.images.erase(without2.images.begin() + 1);
  for (ModelPoint& point : without2.points) {
    std::erase_if(point.track, [](const auto& t) { return t.first == 1; });
    for (auto& t : point.track) t.first -= t.first > 1;
  }
  const DenseUpdate u3 = dense.update(without2, images);
  EXPECT_EQ(u3.new_depth_maps, std::vector<std::string>{"again"});
  EXPECT_NE(dense.raw_depth_map("again"), nullptr);
}

// Per filtered map: the share of its depths within 2 % of their distance
// from the street's surfaces.
std::map<std::string, double> share_on_site(const DenseReconstruction& dense) {
  const Eigen::Vector3d centre = street()[2].view.centre();
  std::map<std::string, double> shares;
  for (const DepthMap& map : dense.filtered_depth_maps()) {
    int near = 0, measured = 0;
    for (int y = 0; y < map.depth.rows; ++y)
      for (int x = 0; x < map.depth.cols; ++x) {
        const float z = map.depth.at<float>(y, x);
        if (z <= 0) continue;
        const Eigen::Vector3d X = map.unproject(x, y, z);
        ++measured;
        near += distance_to_site(X) < 0.02 * (X - centre).norm();
      }
    shares[map.id] = measured > 1000 ? static_cast<double>(near) / measured : 0;
  }
  return shares;
}

TEST(DenseStagesReconstruction, ALaneBehindSweepsCoarserUntilItCatchesUp) {
  const SparseTruth truth = sparse_truth(street(), 300, 17);
  const Model all5 = build_model(street(), truth, {0, 1, 2, 3, 4});
  DenseOptions options = small_dense_options();
  options.sweep = PlaneSweepOptions{};  // planes a pixel apart, as served
  options.sweep_budget = 1;
  options.catch_up_backlog = 2;
  DenseReconstruction dense(options);
  // Five views wait; each update sweeps one. While more than two wait the
  // sweep is coarse, then full again.
  std::vector<size_t> caught_up;
  for (int update = 0; update < 5; ++update) {
    const DenseUpdate u = dense.update(all5, street_images());
    ASSERT_EQ(u.new_depth_maps.size(), 1u);
    caught_up.push_back(u.caught_up_maps);
  }
  EXPECT_EQ(caught_up, (std::vector<size_t>{1, 1, 1, 0, 0}));
  // The coarse maps' planes are half as many, and their depths about as
  // good as those of the same views swept at full resolution of depth.
  EXPECT_EQ(catch_up_sweep(options.sweep).plane_step_px, 2);
  EXPECT_EQ(catch_up_sweep(options.sweep).min_planes, 24);
  options.catch_up_backlog = 0;
  DenseReconstruction full(options);
  for (int update = 0; update < 5; ++update) full.update(all5, street_images());
  const std::map<std::string, double> coarse_share = share_on_site(dense);
  const std::map<std::string, double> full_share = share_on_site(full);
  for (const std::string id : {"view0", "view1", "view2"}) {
    std::cout << id << ": " << coarse_share.at(id) << " of the depths on the "
              << "street coarse, " << full_share.at(id) << " full\n";
    EXPECT_GT(coarse_share.at(id), full_share.at(id) - 0.03) << id;
  }
}

TEST(DenseStagesReconstruction, FusedCloudRoundTripsThroughPly) {
  const SparseTruth truth = sparse_truth(street(), 300, 17);
  DenseReconstruction dense(small_dense_options());
  // Two views, each the other's neighbour: two sweeps.
  const DenseUpdate update =
      dense.update(build_model(street(), truth, {1, 2}), street_images());
  EXPECT_EQ(update.new_depth_maps.size(), 2u);
  const std::vector<ColoredPoint> points = dense.points();
  ASSERT_FALSE(points.empty());
  const std::string path = ::testing::TempDir() + "dense_stages_cloud_" +
                           std::to_string(::getpid()) + ".ply";
  write_ply(path, points);
  const std::vector<ColoredPoint> back = read_ply(path);
  std::remove(path.c_str());
  ASSERT_EQ(back.size(), points.size());
  size_t different = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    const ColoredPoint& a = points[i];
    const ColoredPoint& b = back[i];
    if (a.x != b.x || a.y != b.y || a.z != b.z || a.r != b.r || a.g != b.g ||
        a.b != b.b)
      ++different;
  }
  EXPECT_EQ(different, 0u);
}

}  // namespace
}  // namespace arscout::engine
