// The plane sweep, consistency filter and fusion on rendered street scenes
// with exact depth (synthetic_site.h).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <random>

#include <Eigen/Dense>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "arscout/engine/dense.h"
#include "arscout/engine/dense_reconstruction.h"
#include "arscout/engine/synthetic_site.h"
#include "dense/consistency.h"
#include "rendered_street.h"

namespace arscout::engine {
namespace {

using namespace street_fixture;

cv::Mat local_std(const cv::Mat& bgr, int window) {
  cv::Mat gray, g, mean, mean_sq;
  cv::cvtColor(bgr, gray, cv::COLOR_BGR2GRAY);
  gray.convertTo(g, CV_32F);
  cv::boxFilter(g, mean, CV_32F, cv::Size(window, window));
  cv::boxFilter(g.mul(g), mean_sq, CV_32F, cv::Size(window, window));
  cv::Mat var = mean_sq - mean.mul(mean);
  cv::Mat std_dev;
  cv::sqrt(cv::max(var, 0), std_dev);
  return std_dev;
}

struct Accuracy {
  int textured = 0;    // textured pixels some neighbour sees
  int within_1pc = 0;  // of those, estimated within 1 % of the truth
  int estimated = 0;   // pixels with an estimate
  int beyond_5pc = 0;  // of those, more than 5 % off
};

// Over the pixels `region` keeps (true depth, texture, seen by a neighbour).
Accuracy measure(const DepthMap& map, const Rendered& key,
                 const std::vector<const Rendered*>& neighbours,
                 const std::function<bool(int, int)>& region) {
  const cv::Mat texture = local_std(key.image.bgr, 7);
  Accuracy a;
  for (int y = 0; y < map.depth.rows; ++y) {
    for (int x = 0; x < map.depth.cols; ++x) {
      const float truth = key.image.depth.at<float>(y, x);
      const float z = map.depth.at<float>(y, x);
      if (!region(x, y)) continue;
      if (z > 0) {
        ++a.estimated;
        if (truth <= 0 || std::abs(z - truth) > 0.05 * truth) ++a.beyond_5pc;
      }
      if (truth <= 0 || texture.at<float>(y, x) < 4) continue;
      const bool seen = std::any_of(
          neighbours.begin(), neighbours.end(), [&](const Rendered* n) {
            return seen_at(*n, surface_point(key, x, y), 4).has_value();
          });
      if (!seen) continue;
      ++a.textured;
      if (z > 0 && std::abs(z - truth) <= 0.01 * truth) ++a.within_1pc;
    }
  }
  return a;
}

Accuracy measure(const DepthMap& map, const Rendered& key,
                 const std::vector<const Rendered*>& neighbours) {
  return measure(map, key, neighbours, [](int, int) { return true; });
}

class StreetSweep : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    scene_ = &rendered_street({640, 480});
    for (int i = 0; i < kStreetViews; ++i) {
      const Rendered& r = (*scene_)[i];
      views_.push_back(
          dense_view(r, view_id(i), sample_surface(r, 400, 11 + i)));
    }
  }
  static void TearDownTestSuite() {
    scene_ = nullptr;
    views_.clear();
  }

  static DepthMap sweep(int key, const PlaneSweepOptions& options = {},
                        const Eigen::Vector3d& up = Eigen::Vector3d::Zero()) {
    DenseView key_view = views_[key];
    key_view.up = up;
    return sweep_planes(key_view, {&views_[key - 1], &views_[key + 1]},
                        options);
  }

  static const std::vector<Rendered>* scene_;
  static std::vector<DenseView> views_;
};
const std::vector<Rendered>* StreetSweep::scene_ = nullptr;
std::vector<DenseView> StreetSweep::views_;

TEST_F(StreetSweep, FilteredDepthIsAccurateOnTexturedPixels) {
  const auto& s = *scene_;
  DepthMap key = sweep(2);
  // As DenseReconstruction does: a depth stays when a partner agrees.
  const cv::Mat agrees =
      agreement_mask(key, sweep(1), {}) | agreement_mask(key, sweep(3), {});
  const cv::Mat raw = key.depth.clone();
  key.depth.setTo(0, agrees == 0);
  const Accuracy a = measure(key, s[2], {&s[1], &s[3]});
  DepthMap unfiltered = key;
  unfiltered.depth = raw;
  const Accuracy before = measure(unfiltered, s[2], {&s[1], &s[3]});
  RecordProperty("textured", a.textured);
  std::cout << "textured " << a.textured << " within 1% " << a.within_1pc
            << " estimated " << a.estimated << " beyond 5% " << a.beyond_5pc
            << " (unfiltered: within " << before.within_1pc << " estimated "
            << before.estimated << " beyond " << before.beyond_5pc << ")\n";
  if (getenv("DENSE_DEBUG")) {
    cv::Mat vis = s[2].image.bgr.clone();
    for (int y = 0; y < vis.rows; ++y)
      for (int x = 0; x < vis.cols; ++x) {
        const float t = s[2].image.depth.at<float>(y, x);
        const float r = raw.at<float>(y, x), f = key.depth.at<float>(y, x);
        if (t <= 0) continue;
        cv::Vec3b& p = vis.at<cv::Vec3b>(y, x);
        if (r <= 0)
          p = {0, 0, 0};  // no raw
        else if (std::abs(r - t) > 0.01 * t)
          p = {0, 0, 255};  // raw wrong
        else if (f <= 0)
          p = {255, 0, 0};  // filtered out
        else
          p = {0, 255, 0};
      }
    cv::imwrite("/tmp/dense_debug.png", vis);
  }
  ASSERT_GT(a.textured, 100000);
  EXPECT_GE(a.within_1pc, 0.90 * a.textured);
  EXPECT_LE(a.beyond_5pc, 0.02 * a.estimated);
}

// The ground, seen at a grazing angle, is measured far better along planes
// parallel to it once the sweep knows which way is up, and the rest of the
// picture no worse. (Fronto-parallel planes only otherwise: on this street
// RANSAC finds the ground among the sparse points too, which real streets'
// few ground points seldom allow.)
TEST_F(StreetSweep, GroundIsSweptAlongTheGroundOnceUpIsKnown) {
  PlaneSweepOptions options;
  options.max_scene_directions = 0;
  const auto& s = *scene_;
  auto on_ground = [&](int x, int y) {
    return s[2].image.depth.at<float>(y, x) > 0 &&
           std::abs(surface_point(s[2], x, y).z()) < 1e-3;
  };
  auto elsewhere = [&](int x, int y) { return !on_ground(x, y); };
  const std::vector<const Rendered*> neighbours{&s[1], &s[3]};
  const DepthMap blind = sweep(2, options);
  const DepthMap upright = sweep(2, options, Eigen::Vector3d::UnitZ());
  const Accuracy ground_before = measure(blind, s[2], neighbours, on_ground);
  const Accuracy ground_after = measure(upright, s[2], neighbours, on_ground);
  const Accuracy rest_before = measure(blind, s[2], neighbours, elsewhere);
  const Accuracy rest_after = measure(upright, s[2], neighbours, elsewhere);
  std::cout << "ground: textured " << ground_after.textured << " within 1% "
            << ground_before.within_1pc << " -> " << ground_after.within_1pc
            << ", beyond 5% " << ground_before.beyond_5pc << "/"
            << ground_before.estimated << " -> " << ground_after.beyond_5pc
            << "/" << ground_after.estimated << "; elsewhere within 1% "
            << rest_before.within_1pc << " -> " << rest_after.within_1pc
            << "\n";
  ASSERT_GT(ground_after.textured, 10000);
  // Measured: 71 % within 1 % -> 95 %.
  EXPECT_GE(ground_after.within_1pc, 0.90 * ground_after.textured);
  EXPECT_GE(ground_after.within_1pc,
            ground_before.within_1pc + 0.1 * ground_after.textured);
  EXPECT_LE(ground_after.beyond_5pc, 0.05 * ground_after.estimated);
  EXPECT_GE(rest_after.within_1pc, 0.98 * rest_before.within_1pc);
}

// Nothing is measured through the ground: with up known, no depth's point
// lies below the ground's last plane (the lowest sparse points beneath the
// camera, 1.6 m, plus the 15 % margin: 24 cm below the ground).
TEST_F(StreetSweep, NoDepthBelowTheGroundOnceUpIsKnown) {
  PlaneSweepOptions options;
  options.max_scene_directions = 0;
  int below_blind = 0, below_upright = 0, past_margin = 0, ground_kept = 0;
  for (int key = 1; key + 1 < kStreetViews; ++key) {
    for (const bool upright : {false, true}) {
      const Eigen::Vector3d up = upright
                                     ? Eigen::Vector3d(Eigen::Vector3d::UnitZ())
                                     : Eigen::Vector3d(Eigen::Vector3d::Zero());
      const DepthMap map = sweep(key, options, up);
      for (int y = 0; y < map.depth.rows; ++y) {
        for (int x = 0; x < map.depth.cols; ++x) {
          const float z = map.depth.at<float>(y, x);
          if (z <= 0) continue;
          const double height = map.unproject(x, y, z).z();
          int& below = upright ? below_upright : below_blind;
          if (height < -0.1) ++below;
          if (upright && height < -0.25) ++past_margin;
          if (upright && std::abs(height) < 0.02) ++ground_kept;
        }
      }
    }
  }
  std::cout << "points 10 cm or more below the ground: " << below_blind
            << " -> " << below_upright << "; on the ground " << ground_kept
            << "\n";
  EXPECT_GT(below_blind, 1000);  // measured: 2407 -> 61
  EXPECT_LE(below_upright, below_blind / 10);
  EXPECT_EQ(past_margin, 0);
  EXPECT_GT(ground_kept, 50000);
}

// A neighbour straight ahead (a scout walking toward the facade): near the
// epipole, the picture's centre, the rays of the two cameras meet at a
// fraction of a degree and the planes' parallax there is under a pixel, so
// the depth is imprecise. The triangulation floor drops the depths seen at
// under 3 degrees, and only those.
TEST_F(StreetSweep, DepthsSeenAtANarrowAngleAreDropped) {
  const Rendered& key = (*scene_)[2];
  Rendered ahead{key.view, {}};
  const Eigen::Vector3d forward = key.view.R.row(2).transpose();
  ahead.view.t = -key.view.R * (key.view.centre() + 1.5 * forward);
  ahead.image = synthetic::render(street_scene(), ahead.view);
  const DenseView neighbour = dense_view(ahead, "ahead", {});
  PlaneSweepOptions options;
  options.max_scene_directions = 0;
  options.min_triangulation_deg = 0;
  const DepthMap all = sweep_planes(views_[2], {&neighbour}, options);
  options.min_triangulation_deg = 3;
  const DepthMap kept = sweep_planes(views_[2], {&neighbour}, options);
  // Relative depth errors by the true angle: under 1 degree, under 3, and
  // 3-6 degrees (past 6 degrees lie the picture's edges, which the camera
  // ahead does not see at all).
  std::vector<double> under1, under3, from3to6;
  int narrow_kept = 0, wide_kept = 0;
  for (int y = 0; y < all.depth.rows; ++y) {
    for (int x = 0; x < all.depth.cols; ++x) {
      const float z = all.depth.at<float>(y, x);
      const float truth = key.image.depth.at<float>(y, x);
      if (z <= 0 || truth <= 0) continue;
      const Eigen::Vector3d X = surface_point(key, x, y);
      const double angle =
          std::acos((key.view.centre() - X)
                        .normalized()
                        .dot((ahead.view.centre() - X).normalized())) *
          180 / M_PI;
      const double error = std::abs(z - truth) / truth;
      const bool stays = kept.depth.at<float>(y, x) > 0;
      if (stays) {
        EXPECT_EQ(kept.depth.at<float>(y, x), z);
      }
      if (angle < 3) {
        (angle < 1 ? under1 : under3).push_back(error);
        narrow_kept += stays;
      } else if (angle < 6) {
        from3to6.push_back(error);
        wide_kept += stays;
      }
    }
  }
  auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  const size_t narrow = under1.size() + under3.size();
  std::cout << "relative depth error, median: under 1 degree " << median(under1)
            << " (" << under1.size() << "), 1-3 degrees " << median(under3)
            << " (" << under3.size() << "), 3-6 degrees " << median(from3to6)
            << " (" << from3to6.size() << "); kept " << narrow_kept << " of "
            << narrow << " under 3 degrees, " << wide_kept << " of "
            << from3to6.size() << " at 3-6\n";
  ASSERT_GT(under1.size(), 1000u);
  ASSERT_GT(from3to6.size(), 10000u);
  // Measured: 1.43 %, 0.48 % and 0.28 %.
  EXPECT_GE(median(under1), 3 * median(from3to6));
  EXPECT_LE(narrow_kept, 0.02 * narrow);
  EXPECT_GE(wide_kept, 0.95 * from3to6.size());
}

}  // namespace
}  // namespace arscout::engine
