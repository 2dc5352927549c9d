// Texturing (engine/mesh.h) on the rendered street: the surface of its
// exact geometry, textured from four views, drawn into a fifth that it was
// not textured from, matches that view's rendering.
#include <cmath>
#include <iostream>

#include <gtest/gtest.h>
#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>

#include "arscout/engine/mesh.h"
#include "arscout/engine/synthetic_site.h"

namespace arscout::engine {
namespace {

namespace syn = synthetic;

// Points every `step` on each quad, with the quad's normal turned toward
// `eye`.
std::vector<ColoredPoint> sample_site(const syn::Site& site, double step,
                                      const Eigen::Vector3d& eye) {
  std::vector<ColoredPoint> points;
  for (const syn::Quad& q : site.quads) {
    Eigen::Vector3d n = q.edge_u.cross(q.edge_v).normalized();
    if (n.dot(eye - q.corner) < 0) n = -n;
    const int nu = static_cast<int>(q.edge_u.norm() / step);
    const int nv = static_cast<int>(q.edge_v.norm() / step);
    for (int i = 0; i <= nu; ++i)
      for (int j = 0; j <= nv; ++j) {
        const Eigen::Vector3d p = q.corner + q.edge_u * (double(i) / nu) +
                                  q.edge_v * (double(j) / nv);
        ColoredPoint c;
        c.x = float(p.x()), c.y = float(p.y()), c.z = float(p.z());
        c.nx = float(n.x()), c.ny = float(n.y()), c.nz = float(n.z());
        c.r = c.g = c.b = 128;
        c.support = 3;
        points.push_back(c);
      }
  }
  return points;
}

TextureView texture_view(const syn::Site& site, const syn::PinholeView& v) {
  const syn::Rendering r = syn::render(site, v, 2);
  return {"view", r.bgr, v.K, v.R, v.t, r.depth};
}

struct StreetTexture : ::testing::Test {
  void SetUp() override {
    site = syn::street_site(3);
    // Three quarters of the usual size: the test runs under the sanitizers.
    views = syn::street_cameras(5, {480, 360}, 420);
    const auto points = sample_site(site, 0.06, {0, 0, 1.6});
    surface = mesh_surface(points, {-8, -2}, {8, 11}, 0.06);
    for (int i : {0, 1, 3, 4}) sources.push_back(texture_view(site, views[i]));
  }
  syn::Site site;
  std::vector<syn::PinholeView> views;
  TexturedMesh surface;
  std::vector<TextureView> sources;
};

TEST_F(StreetTexture, AHeldOutViewMatchesTheTexturedMesh) {
  ASSERT_GT(surface.triangles(), 5000u);
  const TexturedMesh textured = texture_mesh(surface, sources);
  ASSERT_FALSE(textured.atlas.empty());
  ASSERT_EQ(textured.uvs.size(), textured.positions.size());
  for (const Eigen::Vector2f& uv : textured.uvs) {
    ASSERT_GE(uv.minCoeff(), 0.0f);
    ASSERT_LE(uv.maxCoeff(), 1.0f);
  }
  // The middle view, predicted from the four others (holdout_scores
  // textures without it).
  std::vector<TextureView> all = sources;
  all.insert(all.begin() + 2, texture_view(site, views[2]));
  const std::vector<HoldoutScore> scores =
      holdout_scores(surface, all, {}, {2});
  ASSERT_EQ(scores.size(), 1u);
  std::cout << "held-out middle view: covered " << scores[0].covered
            << ", ZNCC " << scores[0].zncc << std::endl;
  EXPECT_GT(scores[0].covered, 0.9);
  EXPECT_GT(scores[0].zncc, 0.7);  // 0.78 here, 0.86 at 640 x 480
}

TEST_F(StreetTexture, AnAtlasLimitScalesThePatchesDown) {
  TextureOptions options;
  options.max_atlas_side = 512;
  const TexturedMesh textured = texture_mesh(surface, sources, options);
  ASSERT_FALSE(textured.atlas.empty());
  EXPECT_LE(std::max(textured.atlas.cols, textured.atlas.rows), 512);
  EXPECT_EQ(textured.triangles(), surface.triangles());
}

TEST(MeshTexture, FacesNoViewSeesKeepTheirColour) {
  std::vector<ColoredPoint> points;
  for (int i = 0; i <= 50; ++i)
    for (int j = 0; j <= 50; ++j) {
      ColoredPoint c;
      c.x = float(i * 0.04), c.y = float(j * 0.04), c.z = 0;
      c.nz = 1;
      c.r = 10, c.g = 200, c.b = 30;
      c.support = 3;
      points.push_back(c);
    }
  const TexturedMesh surface = mesh_surface(points, {-1, -1}, {3, 3}, 0.04);
  ASSERT_FALSE(surface.empty());
  const TexturedMesh textured = texture_mesh(surface, {});
  ASSERT_FALSE(textured.atlas.empty());
  const cv::Vec3b texel = textured.atlas.at<cv::Vec3b>(
      int(textured.uvs[0].y() * textured.atlas.rows),
      int(textured.uvs[0].x() * textured.atlas.cols));
  EXPECT_EQ(texel, cv::Vec3b(30, 200, 10));
}

}  // namespace
}  // namespace arscout::engine
