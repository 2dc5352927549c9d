// The plane sweep, consistency filter and fusion on rendered street scenes
// with exact depth (synthetic_site.h).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
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

Accuracy measure(const DepthMap& map, const Rendered& key,
                 const std::vector<const Rendered*>& neighbours) {
  const cv::Mat texture = local_std(key.image.bgr, 7);
  Accuracy a;
  for (int y = 0; y < map.depth.rows; ++y) {
    for (int x = 0; x < map.depth.cols; ++x) {
      const float truth = key.image.depth.at<float>(y, x);
      const float z = map.depth.at<float>(y, x);
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

  static DepthMap sweep(int key, const PlaneSweepOptions& options = {}) {
    return sweep_planes(views_[key], {&views_[key - 1], &views_[key + 1]},
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

}  // namespace
}  // namespace arscout::engine
