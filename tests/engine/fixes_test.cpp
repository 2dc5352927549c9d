// merge_agrees_with_fixes: two components of one walk, each placed in its
// own frame, with noisy fixes; a true merge similarity agrees with the
// fixes, a false one (as repeated texture gives) does not.
#include "sfm/fixes.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

namespace arscout::engine {
namespace {

constexpr double kHorizontalAcc = 1.5;  // metres, per axis
constexpr double kVerticalAcc = 3.0;

// A walk along a street bending round a corner: camera k of `count`
// stands at a true ENU position; its fix is that position with Gaussian
// noise of the stated accuracy.
Eigen::Vector3d true_position(int k) {
  return k < 20 ? Eigen::Vector3d(2.0 * k, 0, 1.6)
                : Eigen::Vector3d(38, 2.0 * (k - 19), 1.6);
}

// Registers cameras [first, last) into `component`, each at its true
// position mapped by `frame` (the component's own frame: the inverse of
// the similarity that places it in ENU).
void add_cameras(Scene& scene, int first, int last, int component,
                 const Similarity& frame, std::mt19937& rng) {
  std::normal_distribution<double> h(0, kHorizontalAcc), v(0, kVerticalAcc);
  for (int k = first; k < last; ++k) {
    SceneImage image;
    image.registered = true;
    image.component = component;
    image.q = Eigen::Quaterniond(
        Eigen::AngleAxisd(0.3 * k, Eigen::Vector3d::UnitZ()));
    image.t = -(image.q * frame.apply(true_position(k)));
    GeoFix fix;
    fix.h_acc = kHorizontalAcc;
    fix.v_acc = kVerticalAcc;
    image.gps = fix;
    image.gps_enu = true_position(k) + Eigen::Vector3d(h(rng), h(rng), v(rng));
    scene.images.push_back(image);
  }
}

// x -> s R x + t and its inverse.
Similarity similarity(double scale, double yaw_deg, Eigen::Vector3d t) {
  Similarity sim;
  sim.scale = scale;
  sim.R = Eigen::AngleAxisd(yaw_deg * M_PI / 180, Eigen::Vector3d::UnitZ())
              .toRotationMatrix();
  sim.t = t;
  return sim;
}
Similarity inverse(const Similarity& sim) {
  Similarity inv;
  inv.scale = 1 / sim.scale;
  inv.R = sim.R.transpose();
  inv.t = -(inv.R * sim.t) / sim.scale;
  return inv;
}

// Component 0 (cameras 0-29) in ENU; component 1 (30-39, or only 3 of
// them) in a frame of its own, turned, scaled and moved.
struct TwoComponents {
  Scene scene;
  Similarity gone_to_enu;  // the true merge
};
TwoComponents two_components(int gone_cameras, unsigned seed) {
  TwoComponents result;
  std::mt19937 rng(seed);
  add_cameras(result.scene, 0, 30, 0, Similarity{}, rng);
  result.gone_to_enu = similarity(1.7, 40, Eigen::Vector3d(12, -30, 4));
  add_cameras(result.scene, 30, 30 + gone_cameras, 1,
              inverse(result.gone_to_enu), rng);
  return result;
}

TEST(MergeAgreesWithFixes, TheTrueSimilarityAgrees) {
  for (unsigned seed = 1; seed <= 20; ++seed) {
    for (int gone_cameras : {3, 10}) {
      const TwoComponents c = two_components(gone_cameras, seed);
      EXPECT_TRUE(merge_agrees_with_fixes(c.scene, 0, 1, c.gone_to_enu))
          << "seed " << seed << ", " << gone_cameras << " cameras";
    }
  }
}

// A merge off in scale, or moved along the street by more than the fixes'
// noise (a facade repeated 20 m further on), is refused.
TEST(MergeAgreesWithFixes, AFalseSimilarityIsRefused) {
  for (unsigned seed = 1; seed <= 20; ++seed) {
    for (int gone_cameras : {3, 10}) {
      const TwoComponents c = two_components(gone_cameras, seed);
      Similarity scaled = c.gone_to_enu;
      scaled.scale *= 0.55;
      Similarity moved = c.gone_to_enu;
      moved.t += Eigen::Vector3d(20, 0, 0);
      Similarity turned = c.gone_to_enu;
      turned.R =
          Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()) * turned.R;
      for (const Similarity& wrong : {scaled, moved, turned}) {
        EXPECT_FALSE(merge_agrees_with_fixes(c.scene, 0, 1, wrong))
            << "seed " << seed << ", " << gone_cameras << " cameras";
      }
    }
  }
}

// Without fixes on one side the fixes cannot tell, and the merge stands.
TEST(MergeAgreesWithFixes, NoFixesOnOneSideCannotRefuse) {
  TwoComponents c = two_components(10, 3);
  for (SceneImage& image : c.scene.images)
    if (image.component == 1) image.gps.reset();
  Similarity wrong = c.gone_to_enu;
  wrong.scale *= 0.55;
  EXPECT_TRUE(merge_agrees_with_fixes(c.scene, 0, 1, wrong));
}

}  // namespace
}  // namespace arscout::engine
