// The surface of oriented points (engine/mesh.h): a box building sampled
// as a dense cloud would give it, meshed in two columns that meet at x = 0.
#include <algorithm>
#include <cmath>
#include <random>
#include <set>
#include <tuple>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "arscout/engine/mesh.h"
#include "mesh/point_hash.h"

namespace arscout::engine {
namespace {

// A box [-2, 2] x [-2, 2] x [0, 3] (walls and roof, no floor).
constexpr double kHalf = 2.0, kHeight = 3.0;

double box_signed_distance(const Eigen::Vector3d& p) {
  const Eigen::Vector3d centre(0, 0, kHeight / 2);
  const Eigen::Vector3d half(kHalf, kHalf, kHeight / 2);
  const Eigen::Vector3d q = (p - centre).cwiseAbs() - half;
  return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}

ColoredPoint oriented_point(const Eigen::Vector3d& p, const Eigen::Vector3d& n,
                            std::mt19937& rng, double noise) {
  std::normal_distribution<double> jitter(0, noise);
  const Eigen::Vector3d q = p + n * jitter(rng);
  ColoredPoint c;
  c.x = static_cast<float>(q.x());
  c.y = static_cast<float>(q.y());
  c.z = static_cast<float>(q.z());
  c.nx = static_cast<float>(n.x());
  c.ny = static_cast<float>(n.y());
  c.nz = static_cast<float>(n.z());
  c.r = 200;
  c.g = 120;
  c.b = 40;
  c.support = 4;
  return c;
}

// Points every `step` on the walls and the roof, with normal noise.
std::vector<ColoredPoint> box_cloud(double step, double noise) {
  std::mt19937 rng(7);
  std::vector<ColoredPoint> points;
  const int n = static_cast<int>(2 * kHalf / step);
  const int h = static_cast<int>(kHeight / step);
  for (int i = 0; i <= n; ++i) {
    const double a = -kHalf + i * step;
    for (int k = 0; k <= h; ++k) {
      const double z = k * step;
      points.push_back(oriented_point({a, -kHalf, z}, {0, -1, 0}, rng, noise));
      points.push_back(oriented_point({a, kHalf, z}, {0, 1, 0}, rng, noise));
      points.push_back(oriented_point({-kHalf, a, z}, {-1, 0, 0}, rng, noise));
      points.push_back(oriented_point({kHalf, a, z}, {1, 0, 0}, rng, noise));
    }
    for (int j = 0; j <= n; ++j)
      points.push_back(oriented_point({a, -kHalf + j * step, kHeight},
                                      {0, 0, 1}, rng, noise));
  }
  return points;
}

constexpr double kVoxel = 0.04;

TexturedMesh left_half(const std::vector<ColoredPoint>& points) {
  return mesh_surface(points, {-10, -10}, {0, 10}, kVoxel);
}
TexturedMesh right_half(const std::vector<ColoredPoint>& points) {
  return mesh_surface(points, {0, -10}, {10, 10}, kVoxel);
}

std::set<std::tuple<float, float, float>> vertices_at_x0(
    const TexturedMesh& m) {
  std::set<std::tuple<float, float, float>> out;
  for (const Eigen::Vector3f& p : m.positions)
    if (std::abs(p.x()) < 1e-6f) out.insert({p.x(), p.y(), p.z()});
  return out;
}

TEST(MeshSurface, FollowsTheBoxWithinAFractionOfACell) {
  const auto points = box_cloud(kVoxel, 0.003);
  const TexturedMesh left = left_half(points);
  ASSERT_GT(left.triangles(), 1000u);
  std::vector<double> errors;
  for (const Eigen::Vector3f& p : left.positions)
    errors.push_back(std::abs(box_signed_distance(p.cast<double>())));
  std::sort(errors.begin(), errors.end());
  const double cell = 2 * kVoxel;
  EXPECT_LT(errors[errors.size() * 9 / 10], 0.1 * cell);
  EXPECT_LT(errors.back(), 1.5 * cell);
  ASSERT_EQ(left.colors.size(), left.positions.size());
  EXPECT_EQ(left.colors[0][0], 200);
}

TEST(MeshSurface, CoversTheSampledSurface) {
  const auto points = box_cloud(kVoxel, 0.003);
  TexturedMesh both = left_half(points);
  const TexturedMesh right = right_half(points);
  both.positions.insert(both.positions.end(), right.positions.begin(),
                        right.positions.end());
  // Every input point (on the surface) has a vertex within a cell.
  const double cell = 2 * kVoxel;
  const mesh::PointHash vertices(both.positions, cell);
  int covered = 0, total = 0;
  for (const ColoredPoint& p : points) {
    bool near = false;
    vertices.within(Eigen::Vector3d(p.x, p.y, p.z), cell,
                    [&](std::uint32_t, double) { near = true; });
    ++total;
    covered += near;
  }
  EXPECT_GT(covered, total * 97 / 100) << covered << " of " << total;
}

TEST(MeshSurface, TwoColumnsMeetEdgeToEdge) {
  const auto points = box_cloud(kVoxel, 0.003);
  // Untrimmed: the trim drops a triangle on one side of the border and
  // keeps its neighbour on the other where the rim below the walls ends,
  // as one surface over both columns would (the service's
  // MeshBuilder.TheTilesTogetherAreTheSurfaceMadeAsOne checks that).
  SurfaceOptions options;
  options.trim_cells = 0;
  const auto left = vertices_at_x0(
      mesh_surface(points, {-10, -10}, {0, 10}, kVoxel, options));
  const auto right =
      vertices_at_x0(mesh_surface(points, {0, -10}, {10, 10}, kVoxel, options));
  ASSERT_GT(left.size(), 50u);
  EXPECT_EQ(left, right);
}

// The largest distance from a triangle's centre to its nearest point.
double farthest_centre(const TexturedMesh& m,
                       const std::vector<ColoredPoint>& points) {
  std::vector<Eigen::Vector3f> positions;
  for (const ColoredPoint& p : points) positions.emplace_back(p.x, p.y, p.z);
  const mesh::PointHash hash(positions, 0.5);
  double farthest = 0;
  for (std::size_t t = 0; t + 2 < m.indices.size(); t += 3) {
    const Eigen::Vector3d centre =
        ((m.positions[m.indices[t]] + m.positions[m.indices[t + 1]] +
          m.positions[m.indices[t + 2]]) /
         3)
            .cast<double>();
    double nearest = 0.5;
    hash.within(centre, 0.5, [&](std::uint32_t, double d2) {
      nearest = std::min(nearest, std::sqrt(d2));
    });
    farthest = std::max(farthest, nearest);
  }
  return farthest;
}

TEST(MeshSurface, NoTriangleLiesFartherThanTheTrimFromThePoints) {
  // The box's points with a square window cut out of a wall: the blending
  // bridges into the hole and rims its edge, past the data.
  std::vector<ColoredPoint> points = box_cloud(kVoxel, 0.003);
  std::erase_if(points, [](const ColoredPoint& p) {
    return p.y < -kHalf + 0.05 && std::abs(p.x + 1) < 0.3 &&
           std::abs(p.z - 1.5) < 0.3;
  });
  const double cell = 2 * kVoxel;
  SurfaceOptions untrimmed;
  untrimmed.trim_cells = 0;
  const TexturedMesh loose =
      mesh_surface(points, {-10, -10}, {0, 10}, kVoxel, untrimmed);
  const TexturedMesh trimmed = left_half(points);
  EXPECT_GT(farthest_centre(loose, points), 1.2 * cell);
  EXPECT_LE(farthest_centre(trimmed, points), 1.0 * cell + 1e-6);
  // What is measured stays: nearly all of it.
  EXPECT_GT(trimmed.triangles(), loose.triangles() * 97 / 100);
}

TEST(MeshSurface, TrianglesFaceTheNormalsSide) {
  const auto points = box_cloud(kVoxel, 0.003);
  const TexturedMesh m = left_half(points);
  int agree = 0;
  const auto& p = m.positions;
  for (std::size_t t = 0; t < m.indices.size(); t += 3) {
    const Eigen::Vector3d a = p[m.indices[t]].cast<double>();
    const Eigen::Vector3d b = p[m.indices[t + 1]].cast<double>();
    const Eigen::Vector3d c = p[m.indices[t + 2]].cast<double>();
    const Eigen::Vector3d centre = (a + b + c) / 3;
    const Eigen::Vector3d normal = (b - a).cross(c - a);
    // Outward: the distance grows along the triangle's normal.
    const double step = 0.01;
    const double outward =
        box_signed_distance(centre + step * normal.normalized()) -
        box_signed_distance(centre);
    agree += outward > 0;
  }
  EXPECT_GT(agree, static_cast<int>(m.triangles() * 98 / 100));
}

TEST(MeshSurface, LeavesAFloaterAndEmptySpaceAlone) {
  auto points = box_cloud(kVoxel, 0.003);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int i = 0; i < 12; ++i)
    points.push_back(oriented_point(
        {-6 + 0.02 * u(rng), 0.02 * u(rng), 1},
        Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized(), rng, 0));
  SurfaceOptions options;
  options.min_piece_area_cells = 0;
  const TexturedMesh all =
      mesh_surface(points, {-10, -10}, {0, 10}, kVoxel, options);
  int near = 0;
  for (const Eigen::Vector3f& v : all.positions) near += v.x() < -3.0f;
  ASSERT_GT(near, 0) << "the floater makes a blob without the cleanup";
  const TexturedMesh m = left_half(points);
  for (const Eigen::Vector3f& v : m.positions)
    ASSERT_GT(v.x(), -3.0f) << "a vertex near the floater";
}

TEST(MeshSurface, LowSupportPointsMakeNoSurface) {
  auto points = box_cloud(kVoxel, 0.003);
  for (ColoredPoint& p : points) p.support = 2;
  SurfaceOptions options;
  options.min_support = 3;
  EXPECT_TRUE(
      mesh_surface(points, {-10, -10}, {0, 10}, kVoxel, options).empty());
  EXPECT_FALSE(left_half(points).empty());  // the default takes every fused
}

TEST(MeshLevels, EachLevelKeepsAboutAQuarterAndTheBorder) {
  const auto points = box_cloud(kVoxel, 0.003);
  const TexturedMesh left = left_half(points);
  const std::vector<MeshLevel> levels = mesh_levels(left, 3);
  ASSERT_EQ(levels.size(), 3u);
  EXPECT_EQ(levels[0].geometric_error, 0);
  const auto border = vertices_at_x0(left);
  for (std::size_t l = 1; l < levels.size(); ++l) {
    EXPECT_LT(levels[l].mesh.triangles(), levels[l - 1].mesh.triangles() / 3);
    EXPECT_GE(levels[l].geometric_error, levels[l - 1].geometric_error);
    EXPECT_LT(levels[l].geometric_error, 0.5);
    EXPECT_EQ(vertices_at_x0(levels[l].mesh), border) << "level " << l;
    EXPECT_EQ(levels[l].mesh.colors.size(), levels[l].mesh.positions.size());
  }
}

}  // namespace
}  // namespace arscout::engine
