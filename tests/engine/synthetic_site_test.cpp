// The synthetic site renderer: its depth is exact (so dense stereo can be
// checked against it), its images are deterministic and consistent across
// views (brightness constancy), and its textures are rich enough for
// window matching. Geometry is checked independently of the renderer: the
// test solves each ray-quad intersection as a 3x3 linear system.
#include "arscout/engine/synthetic_site.h"
#include "ray_quad.h"

#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Dense>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace arscout::engine::synthetic {
namespace {

Eigen::Vector3d back_project(const PinholeView& view, double x, double y,
                             double depth) {
  const Eigen::Vector3d ray = view.K.inverse() * Eigen::Vector3d(x, y, 1);
  return view.R.transpose() * (depth * ray / ray.z() - view.t);
}

// Pixel coordinates and camera depth.
Eigen::Vector3d project(const PinholeView& view, const Eigen::Vector3d& world) {
  const Eigen::Vector3d camera = view.R * world + view.t;
  const Eigen::Vector3d pixel = view.K * (camera / camera.z());
  return {pixel.x(), pixel.y(), camera.z()};
}

double plane_distance(const Quad& quad, const Eigen::Vector3d& point) {
  const Eigen::Vector3d normal = quad.edge_u.cross(quad.edge_v).normalized();
  return std::abs(normal.dot(point - quad.corner));
}

// 0 when no quad is hit, as in the rendering.
double nearest_depth(const Site& site, const PinholeView& view, double x,
                     double y) {
  double nearest = std::numeric_limits<double>::infinity();
  for (const Quad& quad : site.quads) {
    if (auto depth = ray_quad_depth(view, x, y, quad)) {
      nearest = std::min(nearest, *depth);
    }
  }
  return std::isinf(nearest) ? 0.0 : nearest;
}

// Index of the quad nearest to `point` among those whose parallelogram
// holds its projection on their plane (with tolerance `slack` in s and t);
// -1 when none does.
int quad_at(const Site& site, const Eigen::Vector3d& point, double slack) {
  int best = -1;
  double best_distance = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < site.quads.size(); ++i) {
    const Quad& quad = site.quads[i];
    Eigen::Matrix3d frame;
    frame << quad.edge_u, quad.edge_v,
        quad.edge_u.cross(quad.edge_v).normalized();
    const Eigen::Vector3d st_d = frame.inverse() * (point - quad.corner);
    if (st_d.head<2>().minCoeff() < -slack ||
        st_d.head<2>().maxCoeff() > 1 + slack) {
      continue;
    }
    if (std::abs(st_d(2)) < best_distance) {
      best_distance = std::abs(st_d(2));
      best = static_cast<int>(i);
    }
  }
  return best;
}

// The facade is the only surface in the plane y = 10 (the ground meets it
// along a line).
bool on_facade(const Eigen::Vector3d& point) {
  return std::abs(point.y() - 10) < 1e-5;
}

cv::Mat gray_of(const cv::Mat& bgr) {
  cv::Mat gray, gray_f;
  cv::cvtColor(bgr, gray, cv::COLOR_BGR2GRAY);
  gray.convertTo(gray_f, CV_32F);
  return gray_f;
}

cv::Mat local_std(const cv::Mat& gray, int window) {
  cv::Mat mean, mean_sq;
  cv::boxFilter(gray, mean, CV_32F, {window, window});
  cv::boxFilter(gray.mul(gray), mean_sq, CV_32F, {window, window});
  cv::Mat variance = cv::max(mean_sq - mean.mul(mean), 0.0);
  cv::Mat deviation;
  cv::sqrt(variance, deviation);
  return deviation;
}

Eigen::Matrix3d centred_k(cv::Size size, double focal) {
  Eigen::Matrix3d K;
  K << focal, 0, (size.width - 1) / 2.0, 0, focal, (size.height - 1) / 2.0, 0,
      0, 1;
  return K;
}

// Two neighbouring street views, rendered once for the whole suite (each
// full-size render costs a few hundred milliseconds).
class SyntheticSite : public ::testing::Test {
 protected:
  struct Shared {
    Site site = street_site();
    std::vector<PinholeView> views = street_cameras(5);
    Rendering a = render(site, views[1]);
    Rendering b = render(site, views[2]);
  };

  static void SetUpTestSuite() { shared_ = std::make_unique<Shared>(); }
  static void TearDownTestSuite() { shared_.reset(); }

  static inline std::unique_ptr<Shared> shared_;
};

TEST_F(SyntheticSite, DepthBackProjectsOntoTheNearestQuad) {
  const Site& site = shared_->site;
  // A street view, and one tilted up so that part of it is sky.
  const cv::Size small(160, 120);
  const PinholeView up =
      look_at({0, 0, 1.6}, {0, 10, 12}, centred_k(small, 140), small);
  const std::vector<std::pair<PinholeView, Rendering>> cases = {
      {shared_->views[1], shared_->a}, {up, render(site, up, 1)}};
  int surfaces = 0, sky = 0;
  for (const auto& [view, rendering] : cases) {
    for (int y = 0; y < view.size.height; y += 7) {
      for (int x = 0; x < view.size.width; x += 7) {
        const double depth = rendering.depth.at<float>(y, x);
        const double expected = nearest_depth(site, view, x, y);
        if (expected == 0) {
          EXPECT_EQ(depth, 0) << x << "," << y;
          ++sky;
          continue;
        }
        ++surfaces;
        // Depth is stored as float: exact up to its rounding.
        EXPECT_NEAR(depth, expected, expected * 1e-7) << x << "," << y;
        const Eigen::Vector3d point = back_project(view, x, y, depth);
        const int quad = quad_at(site, point, 1e-6);
        ASSERT_GE(quad, 0) << x << "," << y;
        // Float rounding of depths below 16 m moves a point < 0.5 um.
        EXPECT_LT(plane_distance(site.quads[quad], point), 1e-6);
        const Eigen::Vector3d pixel = project(view, point);
        EXPECT_NEAR(pixel.x(), x, 1e-6);
        EXPECT_NEAR(pixel.y(), y, 1e-6);
      }
    }
  }
  EXPECT_GT(surfaces, 5000);
  EXPECT_GT(sky, 50);
}

TEST_F(SyntheticSite, FrontoParallelFacadeDepthIsExact) {
  // Principal point on a pixel centre, looking straight at the facade.
  const cv::Size size(641, 481);
  const PinholeView view =
      look_at({0, 0, 2.5}, {0, 10, 2.5}, centred_k(size, 560), size);
  const Rendering rendering = render(shared_->site, view, 1);
  EXPECT_NEAR(rendering.depth.at<float>(240, 320), 10.0, 1e-9);
  // The whole centre row is facade (the box is lower), all at depth 10.
  for (int x = 0; x < size.width; ++x) {
    EXPECT_NEAR(rendering.depth.at<float>(240, x), 10.0, 1e-9) << x;
  }
}

TEST_F(SyntheticSite, RenderingIsDeterministic) {
  // A smaller view keeps the three renders quick.
  const PinholeView view = street_cameras(2, {320, 240}, 280)[1];
  const Rendering first = render(shared_->site, view);
  const Rendering second = render(shared_->site, view);
  EXPECT_EQ(cv::norm(first.bgr, second.bgr, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(first.depth, second.depth, cv::NORM_INF), 0);

  // Nor may the split of rows among threads matter.
  const int threads = cv::getNumThreads();
  cv::setNumThreads(1);
  const Rendering serial = render(shared_->site, view);
  cv::setNumThreads(threads);
  EXPECT_EQ(cv::norm(serial.bgr, first.bgr, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(serial.depth, first.depth, cv::NORM_INF), 0);

  // Depth is the centre ray's whatever the supersampling, and another seed
  // changes the patterns, never the geometry.
  const Rendering centres = render(shared_->site, view, 1);
  const Rendering reseeded = render(street_site(2), view, 1);
  EXPECT_EQ(cv::norm(centres.depth, first.depth, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(reseeded.depth, centres.depth, cv::NORM_INF), 0);
  EXPECT_GT(cv::norm(reseeded.bgr, centres.bgr, cv::NORM_L1), 0);
}

TEST_F(SyntheticSite, FacadeIsTexturedForSevenBySevenWindows) {
  const PinholeView& view = shared_->views[1];
  const Rendering& rendering = shared_->a;
  const cv::Mat deviation = local_std(gray_of(rendering.bgr), 7);
  int facade = 0, textured = 0;
  for (int y = 0; y < view.size.height; ++y) {
    for (int x = 0; x < view.size.width; ++x) {
      const float depth = rendering.depth.at<float>(y, x);
      if (depth == 0) continue;
      const Eigen::Vector3d point = back_project(view, x, y, depth);
      if (!on_facade(point)) continue;
      ++facade;
      textured += deviation.at<float>(y, x) > 8;
    }
  }
  ASSERT_GT(facade, 100000);
  RecordProperty("textured_fraction",
                 std::to_string(textured / static_cast<double>(facade)));
  EXPECT_GE(textured, 0.9 * facade);
}

// Every texture at 1.5 cm per pixel, averaged over each pixel as the
// renderer does, at the darkest brightness a street_site quad gets.
TEST_F(SyntheticSite, EveryTextureIsTexturedAtCentimetreScale) {
  constexpr double kPixel = 0.015;
  constexpr int kSide = 120, kSub = 3;
  for (Texture texture : {Texture::kBrick, Texture::kPlaster, Texture::kAsphalt,
                          Texture::kNoise}) {
    cv::Mat bgr(kSide, kSide, CV_8UC3);
    for (int y = 0; y < kSide; ++y) {
      for (int x = 0; x < kSide; ++x) {
        cv::Vec3f sum(0, 0, 0);
        for (int j = 0; j < kSub; ++j) {
          for (int i = 0; i < kSub; ++i) {
            sum += texture_colour(texture, 5, (x + (i + 0.5) / kSub) * kPixel,
                                  (y + (j + 0.5) / kSub) * kPixel);
          }
        }
        const cv::Vec3f colour = sum * (0.7f * 255 / (kSub * kSub));
        bgr.at<cv::Vec3b>(y, x) = colour;
      }
    }
    const cv::Mat deviation = local_std(gray_of(bgr), 7);
    const cv::Mat inner = deviation(cv::Rect(3, 3, kSide - 6, kSide - 6));
    const double fraction =
        cv::countNonZero(inner > 8) / static_cast<double>(inner.total());
    RecordProperty(
        "textured_fraction_" + std::to_string(static_cast<int>(texture)),
        std::to_string(fraction));
    EXPECT_GE(fraction, 0.9) << "texture " << static_cast<int>(texture);
  }
}

// Compares pixels of A with the pixel of B whose centre the same facade
// point projects to (within 0.1 px). Interpolating B instead would measure
// mostly the interpolation error on pixel-scale texture (about 8 levels by
// itself) rather than the renderer's consistency.
TEST_F(SyntheticSite, FacadeColourIsConsistentAcrossViews) {
  const PinholeView& view_a = shared_->views[1];
  const PinholeView& view_b = shared_->views[2];
  const cv::Mat gray_a = gray_of(shared_->a.bgr);
  const cv::Mat gray_b = gray_of(shared_->b.bgr);
  const cv::Rect inside_b({0, 0}, view_b.size);
  double total = 0;
  int samples = 0;
  for (int y = 0; y < view_a.size.height; ++y) {
    for (int x = 0; x < view_a.size.width; ++x) {
      const float depth = shared_->a.depth.at<float>(y, x);
      if (depth == 0) continue;
      const Eigen::Vector3d point = back_project(view_a, x, y, depth);
      if (!on_facade(point)) continue;
      const Eigen::Vector3d in_b = project(view_b, point);
      const cv::Point pixel_b(static_cast<int>(std::lround(in_b.x())),
                              static_cast<int>(std::lround(in_b.y())));
      if (!inside_b.contains(pixel_b) || std::abs(in_b.x() - pixel_b.x) > 0.1 ||
          std::abs(in_b.y() - pixel_b.y) > 0.1) {
        continue;
      }
      // Occluded in B (by the box).
      const float depth_b = shared_->b.depth.at<float>(pixel_b);
      if (std::abs(depth_b - in_b.z()) > 0.01 * in_b.z()) continue;
      total += std::abs(gray_a.at<float>(y, x) - gray_b.at<float>(pixel_b));
      ++samples;
    }
  }
  ASSERT_GT(samples, 5000);
  RecordProperty("mean_abs_gray_difference", std::to_string(total / samples));
  EXPECT_LT(total / samples, 10);
}

TEST_F(SyntheticSite, LookAtGivesARotationFacingTheTarget) {
  const cv::Size size(640, 480);
  const Eigen::Matrix3d K = centred_k(size, 560);
  const std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> cases = {
      {{0, 0, 1.6}, {0, 10, 2.5}},
      {{3, -4, 20}, {-1, 2, 0}},
      {{-5, 7, 0}, {-6, 2, 0.3}}};
  for (const auto& [centre, target] : cases) {
    const PinholeView view = look_at(centre, target, K, size);
    const Eigen::Matrix3d& R = view.R;
    EXPECT_LT((R * R.transpose() - Eigen::Matrix3d::Identity()).norm(), 1e-12);
    EXPECT_NEAR(R.determinant(), 1, 1e-12);
    const Eigen::Vector3d forward = (target - centre).normalized();
    EXPECT_LT((R.row(2).transpose() - forward).norm(), 1e-12);
    EXPECT_LT((view.centre() - centre).norm(), 1e-12);
    EXPECT_NEAR(R(0, 2), 0, 1e-12);  // image x horizontal
    EXPECT_LT(R(1, 2), 0);           // image y down in the world
    const Eigen::Vector3d pixel = project(view, target);
    EXPECT_NEAR(pixel.x(), K(0, 2), 1e-9);
    EXPECT_NEAR(pixel.y(), K(1, 2), 1e-9);
    EXPECT_GT(pixel.z(), 0);
  }
  EXPECT_THROW(look_at({0, 0, 0}, {0, 0, 5}, K, size), std::invalid_argument);
  EXPECT_THROW(look_at({1, 2, 3}, {1, 2, -3}, K, size), std::invalid_argument);
  EXPECT_THROW(look_at({1, 2, 3}, {1, 2, 3}, K, size), std::invalid_argument);
}

TEST_F(SyntheticSite, StreetCamerasConvergeOnTheFacade) {
  const std::vector<PinholeView>& views = shared_->views;
  ASSERT_EQ(views.size(), 5u);
  for (size_t i = 0; i < views.size(); ++i) {
    const Eigen::Vector3d centre = views[i].centre();
    EXPECT_NEAR(centre.x(), -2 + static_cast<double>(i), 1e-12);
    EXPECT_NEAR(centre.y(), 0, 1e-12);
    EXPECT_NEAR(centre.z(), 1.6, 1e-12);
    const Eigen::Vector3d aim = project(views[i], {0, 10, 2.5});
    EXPECT_NEAR(aim.x(), 319.5, 1e-9);
    EXPECT_NEAR(aim.y(), 239.5, 1e-9);
  }
  EXPECT_NEAR(street_cameras(1)[0].centre().x(), 0, 1e-12);
  EXPECT_THROW(street_cameras(0), std::invalid_argument);
}

TEST_F(SyntheticSite, NorthLookingCameraSeesEveryQuad) {
  const Site& site = shared_->site;
  const cv::Size size(320, 240);
  const PinholeView view =
      look_at({1.5, 1, 1.6}, {1.5, 10, 1.6}, centred_k(size, 280), size);
  const Rendering rendering = render(site, view, 1);
  std::vector<int> pixels(site.quads.size(), 0);
  for (int y = 0; y < size.height; ++y) {
    for (int x = 0; x < size.width; ++x) {
      const float depth = rendering.depth.at<float>(y, x);
      if (depth == 0) continue;
      const int quad = quad_at(site, back_project(view, x, y, depth), 1e-6);
      if (quad >= 0) ++pixels[quad];
    }
  }
  // Facade, ground, side wall, and the box's front (the others are hidden
  // or edge-on from here).
  for (int quad : {0, 1, 2, 3}) {
    EXPECT_GT(pixels[quad], 200) << "quad " << quad;
  }
}

TEST_F(SyntheticSite, SkyIsPlainAndBoxFacesDifferInBrightness) {
  const cv::Size size(160, 120);
  const PinholeView up =
      look_at({0, 0, 1.6}, {0, 10, 12}, centred_k(size, 140), size);
  const Rendering rendering = render(shared_->site, up, 2);
  // Away from the anti-aliased skyline, where sub-pixel rays hit the facade.
  cv::Mat sky;
  cv::erode(rendering.depth == 0, sky, cv::Mat());
  ASSERT_GT(cv::countNonZero(sky), 100);
  cv::Scalar mean, deviation;
  cv::meanStdDev(rendering.bgr, mean, deviation, sky);
  for (int c = 0; c < 3; ++c) EXPECT_EQ(deviation[c], 0);
  EXPECT_GT(mean[0], mean[2]);  // blue

  // The box's front and east faces with the same texture and seed: only
  // their brightness tells them apart.
  const Site street = street_site();
  Site box{{street.quads[3], street.quads[6]}};
  box.quads[1].seed = box.quads[0].seed;
  const cv::Size box_size(200, 150);
  const PinholeView corner = look_at({3, 3, 1.6}, {-0.5, 6.75, 0.6},
                                     centred_k(box_size, 150), box_size);
  const Rendering rendering_box = render(box, corner, 1);
  const cv::Mat gray = gray_of(rendering_box.bgr);
  double sum[2] = {0, 0};
  int count[2] = {0, 0};
  for (int y = 0; y < box_size.height; ++y) {
    for (int x = 0; x < box_size.width; ++x) {
      const float depth = rendering_box.depth.at<float>(y, x);
      if (depth == 0) continue;
      const int face = quad_at(box, back_project(corner, x, y, depth), 1e-6);
      ASSERT_GE(face, 0);
      sum[face] += gray.at<float>(y, x);
      ++count[face];
    }
  }
  ASSERT_GT(count[0], 1000);
  ASSERT_GT(count[1], 1000);
  EXPECT_GT(std::abs(sum[0] / count[0] - sum[1] / count[1]), 5);
}

TEST_F(SyntheticSite, RenderRejectsBadArguments) {
  const PinholeView& view = shared_->views[0];
  EXPECT_THROW(render(shared_->site, view, 0), std::invalid_argument);
  PinholeView empty = view;
  empty.size = {0, 10};
  EXPECT_THROW(render(shared_->site, empty, 1), std::invalid_argument);
}

}  // namespace
}  // namespace arscout::engine::synthetic
