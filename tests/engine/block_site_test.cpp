// The block scene (synthetic_site.h): deterministic in its seed, a layout
// that the seed changes, a walk with the properties a scale test relies on
// (steps, bursts, bounded turns, a closed loop, views of nearby walls), a
// renderer whose culling keeps every visible quad, and ground truth that
// the evaluator reads back.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include <unistd.h>

#include <gtest/gtest.h>
#include <Eigen/Dense>
#include <opencv2/core.hpp>

#include "arscout/engine/synthetic_site.h"
#include "model_eval.h"
#include "ray_quad.h"

namespace arscout::engine::synthetic {
namespace {

namespace fs = std::filesystem;

constexpr double kPi = 3.14159265358979323846;

// Small images keep the renders of the walk tests cheap; the walk itself
// does not depend on the image size.
const cv::Size kSmall(160, 120);
constexpr double kSmallFocal = 140;

double heading_deg(const PinholeView& view) {
  const Eigen::Vector3d forward = view.R.row(2).transpose();
  return std::atan2(forward.y(), forward.x()) * 180 / kPi;
}

double turn_deg(const PinholeView& a, const PinholeView& b) {
  return std::abs(std::remainder(heading_deg(b) - heading_deg(a), 360.0));
}

bool is_wall(const Quad& quad) { return quad.edge_v.z() > 0; }

// Horizontal distance from `point` to the nearest wall.
double wall_distance(const Site& site, const Eigen::Vector3d& point) {
  double nearest = std::numeric_limits<double>::infinity();
  for (const Quad& quad : site.quads) {
    if (!is_wall(quad)) continue;
    const Eigen::Vector2d a = quad.corner.head<2>();
    const Eigen::Vector2d u = quad.edge_u.head<2>();
    const double s =
        std::clamp(u.dot(point.head<2>() - a) / u.squaredNorm(), 0.0, 1.0);
    nearest = std::min(nearest, (a + s * u - point.head<2>()).norm());
  }
  return nearest;
}

TEST(BlockScene, SameSeedSameSceneBitForBit) {
  const BlockScene a = block_scene(5, 80, kSmall, kSmallFocal);
  const BlockScene b = block_scene(5, 80, kSmall, kSmallFocal);
  ASSERT_EQ(a.site.quads.size(), b.site.quads.size());
  for (size_t i = 0; i < a.site.quads.size(); ++i) {
    const Quad &p = a.site.quads[i], &q = b.site.quads[i];
    EXPECT_TRUE(p.corner == q.corner && p.edge_u == q.edge_u &&
                p.edge_v == q.edge_v && p.texture == q.texture &&
                p.seed == q.seed)
        << i;
  }
  ASSERT_EQ(a.views.size(), 80u);
  ASSERT_EQ(b.views.size(), 80u);
  for (size_t i = 0; i < a.views.size(); ++i) {
    EXPECT_TRUE(a.views[i].R == b.views[i].R && a.views[i].t == b.views[i].t &&
                a.views[i].K == b.views[i].K)
        << i;
  }
}

// Another seed moves buildings and the walk, not just the patterns: the
// sorted footprints and heights differ, and so does the route's extent.
TEST(BlockScene, AnotherSeedAnotherLayout) {
  const auto layout = [](uint32_t seed) {
    const BlockScene scene = block_scene(seed, 120, kSmall, kSmallFocal);
    std::vector<std::tuple<double, double, double>> roofs;
    for (const Quad& quad : scene.site.quads) {
      if (quad.corner.z() > 0 && !is_wall(quad)) {
        roofs.emplace_back(quad.edge_u.norm(), quad.edge_v.norm(),
                           quad.corner.z());
      }
    }
    std::sort(roofs.begin(), roofs.end());
    Eigen::Vector2d low(1e9, 1e9), high(-1e9, -1e9);
    for (const PinholeView& view : scene.views) {
      low = low.cwiseMin(view.centre().head<2>());
      high = high.cwiseMax(view.centre().head<2>());
    }
    return std::make_pair(roofs, (high - low).norm());
  };
  const auto [roofs1, extent1] = layout(1);
  const auto [roofs2, extent2] = layout(2);
  EXPECT_NE(roofs1, roofs2);
  EXPECT_GT(std::abs(extent1 - extent2), 0.5);
}

// Most walls are value noise (unique everywhere), brick is rare (it
// repeats), and every face has its own pattern.
TEST(BlockScene, FacesAreMostlyNoiseEachWithItsOwnSeed) {
  const BlockScene scene = block_scene(3, 400, kSmall, kSmallFocal);
  int walls = 0, noise = 0, brick = 0;
  std::set<uint32_t> seeds;
  for (const Quad& quad : scene.site.quads) {
    seeds.insert(quad.seed);
    if (!is_wall(quad)) continue;
    ++walls;
    noise += quad.texture == Texture::kNoise;
    brick += quad.texture == Texture::kBrick;
  }
  EXPECT_GT(walls, 100);
  EXPECT_GE(noise, 0.6 * walls);
  EXPECT_LE(brick, 0.15 * walls);
  EXPECT_EQ(seeds.size(), scene.site.quads.size());
}

class BlockWalk : public ::testing::TestWithParam<int> {};

// The geometry of the walk, photo to photo.
TEST_P(BlockWalk, StepsBurstsTurnsAndTheLoop) {
  const int n = GetParam();
  const BlockScene scene = block_scene(1, n, kSmall, kSmallFocal);
  const std::vector<PinholeView>& views = scene.views;
  ASSERT_EQ(static_cast<int>(views.size()), n);
  double walked = 0;
  int bursts = 0, run = 1;
  for (int i = 0; i < n; ++i) {
    const PinholeView& view = views[i];
    const Eigen::Vector3d c = view.centre();
    EXPECT_GE(c.z(), 1.5) << i;
    EXPECT_LE(c.z(), 1.7) << i;
    EXPECT_NEAR(view.R(0, 2), 0, 1e-12) << i;  // no roll
    EXPECT_LT(std::abs(std::asin(view.R(2, 2))), 10 * kPi / 180) << i;
    EXPECT_GE(wall_distance(scene.site, c), 2.5) << i;
    if (i == 0) continue;
    const double step = (c - views[i - 1].centre()).norm();
    walked += step;
    EXPECT_LE(turn_deg(views[i - 1], view), 15) << i;
    if (step < 0.05) {  // the same spot: a burst, turning on the spot
      ++run;
      EXPECT_GE(turn_deg(views[i - 1], view), 8) << i;
      EXPECT_LE(turn_deg(views[i - 1], view), 12) << i;
    } else {
      EXPECT_GE(step, 0.3) << i;
      EXPECT_LE(step, 2.0) << i;
    }
    if (step >= 0.05 || i == n - 1) {
      if (run > 1) {
        EXPECT_GE(run, 3) << "burst ending at " << i;
        EXPECT_LE(run, 5) << "burst ending at " << i;
        ++bursts;
      }
      run = 1;
    }
  }
  EXPECT_GE(bursts, n / 20);
  const double mean_step = walked / (n - 1);
  EXPECT_GE(mean_step, 0.7);
  EXPECT_LE(mean_step, 1.0);
  // A closed loop: the last photo near the first, looking the same way.
  EXPECT_LT((views.back().centre() - views.front().centre()).norm(), 2.0);
  EXPECT_LT(turn_deg(views.back(), views.front()), 30);
}

// What the photos see, on a sample rendered small: little sky, the centre
// on a surface 2.5-20 m away, and mostly the ground at the bottom.
TEST_P(BlockWalk, ViewsSeeNearbyWallsAndTheGround) {
  const int n = GetParam();
  const BlockScene scene = block_scene(1, n, kSmall, kSmallFocal);
  const int stride = std::max(1, n / 40);
  double sky_total = 0;
  int sampled = 0, ground_at_bottom = 0;
  for (int i = 0; i < n; i += stride) {
    const PinholeView& view = scene.views[i];
    const Rendering rendering = render(scene.site, view, 1);
    const double sky = cv::countNonZero(rendering.depth == 0) /
                       static_cast<double>(kSmall.area());
    EXPECT_LT(sky, 0.25) << i;
    sky_total += sky;
    const double centre =
        rendering.depth.at<float>(kSmall.height / 2, kSmall.width / 2);
    EXPECT_GE(centre, 2.5) << i;
    EXPECT_LE(centre, 20) << i;
    // The bottom centre pixel back-projected onto z = 0.
    const int y = kSmall.height - 1, x = kSmall.width / 2;
    const double depth = rendering.depth.at<float>(y, x);
    const Eigen::Vector3d ray = view.K.inverse() * Eigen::Vector3d(x, y, 1);
    const Eigen::Vector3d point =
        view.R.transpose() * (depth * ray / ray.z() - view.t);
    ground_at_bottom += depth > 0 && std::abs(point.z()) < 1e-3;
    ++sampled;
  }
  EXPECT_LT(sky_total / sampled, 0.05);
  EXPECT_GE(ground_at_bottom, 0.8 * sampled);
}

INSTANTIATE_TEST_SUITE_P(Sizes, BlockWalk, ::testing::Values(60, 400),
                         [](const auto& info) {
                           return "views" + std::to_string(info.param);
                         });

// The renderer gives each image tile only the quads that may meet its
// rays; with hundreds of quads, a dropped visible one would show as a
// wrong depth. Checked against an exhaustive, independent intersection.
TEST(BlockScene, CullingKeepsEveryVisibleQuad) {
  const BlockScene scene = block_scene(2, 400, kSmall, kSmallFocal);
  int checked = 0;
  for (size_t i = 0; i < scene.views.size(); i += 57) {
    const PinholeView& view = scene.views[i];
    const Rendering rendering = render(scene.site, view, 1);
    for (int y = 0; y < kSmall.height; y += 5) {
      for (int x = 0; x < kSmall.width; x += 5) {
        double nearest = std::numeric_limits<double>::infinity();
        for (const Quad& quad : scene.site.quads) {
          if (auto depth = ray_quad_depth(view, x, y, quad)) {
            nearest = std::min(nearest, *depth);
          }
        }
        const double expected = std::isinf(nearest) ? 0.0 : nearest;
        EXPECT_NEAR(rendering.depth.at<float>(y, x), expected,
                    1e-6 * expected + 1e-9)
            << "view " << i << " pixel " << x << "," << y;
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 5000);
}

// gt_dense_cameras as `arscout render-site --scene block` writes them: the
// evaluator's Strecha reader gets every pose back.
TEST(BlockScene, StrechaCamerasReadBackThroughTheEvaluator) {
  const BlockScene scene = block_scene(4, 60, {1024, 768}, 896);
  const fs::path dir = fs::temp_directory_path() /
                       ("block_site_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  for (size_t i = 0; i < scene.views.size(); i += 7) {
    char name[32];
    std::snprintf(name, sizeof name, "%04zu.jpg", i);
    std::ofstream(dir / (std::string(name) + ".camera"))
        << strecha_camera(scene.views[i]);
  }
  const auto truth = eval::read_strecha_ground_truth(dir.string());
  fs::remove_all(dir);
  ASSERT_EQ(truth.size(), 9u);
  for (const auto& [name, pose] : truth) {
    const PinholeView& view = scene.views[std::stoi(name)];
    EXPECT_LT((pose.R - view.R).norm(), 1e-12) << name;
    EXPECT_LT((pose.centre() - view.centre()).norm(), 1e-9) << name;
  }
}

TEST(BlockScene, RejectsBadArguments) {
  EXPECT_THROW(block_scene(1, 1, kSmall, kSmallFocal), std::invalid_argument);
  EXPECT_THROW(block_scene(1, 60, {0, 120}, kSmallFocal),
               std::invalid_argument);
}

}  // namespace
}  // namespace arscout::engine::synthetic
