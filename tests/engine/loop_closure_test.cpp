// loop_shares: how a loop's correction is spread over the images between
// its ends, on hand-made covisibility graphs with known harmonic shares.
#include "sfm/loop_closure.h"

#include <vector>

#include <gtest/gtest.h>

namespace arscout::engine {
namespace {

// Registered images of component 0, none linked yet.
Scene unlinked_images(int count) {
  Scene scene;
  scene.images.resize(count);
  for (SceneImage& image : scene.images) image.registered = true;
  return scene;
}

// `points` points that images a and b both observe.
void link(Scene& scene, int a, int b, int points) {
  for (int k = 0; k < points; ++k)
    scene.points[scene.next_point_id++].track = {{a, k}, {b, k}};
}

// Two scouts walk one loop at once: A the positions 0-19, B 20-39, one
// photo each in turn, so the order of addition interleaves the two halves
// (index 2k is position k, 2k + 1 is position 20 + k). B's last photo
// closes the loop on A's first. Along the chain of positions the shares
// rise linearly, whatever the order of addition.
TEST(LoopShares, FollowTheChainThroughSpaceNotTheOrderOfAddition) {
  constexpr int kPositions = 40;
  Scene scene = unlinked_images(kPositions);
  auto index_of = [](int position) {
    return position < 20 ? 2 * position : 2 * (position - 20) + 1;
  };
  for (int p = 0; p + 1 < kPositions; ++p)
    link(scene, index_of(p), index_of(p + 1), 12);
  const std::vector<double> shares =
      loop_shares(scene, {index_of(0)}, index_of(kPositions - 1));
  for (int p = 0; p < kPositions; ++p) {
    EXPECT_NEAR(shares[index_of(p)], p / (kPositions - 1.0), 1e-6)
        << "position " << p;
  }
}

// A stiff link (many shared points) takes less of the correction than a
// weak one, as a pose graph weighs each relative pose by its information;
// a spur takes its attachment's share; images of another component, or
// unregistered, or linked to nothing, take none.
TEST(LoopShares, WeighLinksByTheirPointsAndLeaveTheRestAlone) {
  Scene scene = unlinked_images(8);
  link(scene, 0, 1, 10);  // the old end, then a weak link,
  link(scene, 1, 2, 30);  // a stiff one,
  link(scene, 2, 3, 10);  // and the closing image
  link(scene, 2, 4, 50);  // a spur off image 2
  scene.images[5].component = 1;
  link(scene, 2, 5, 50);
  scene.images[6].registered = false;
  link(scene, 2, 6, 50);
  // Image 7: registered, linked to nothing.
  const std::vector<double> shares = loop_shares(scene, {0}, 3);
  // Resistances 1/10 + 1/30 + 1/10 in series: 3 : 1 : 3 of the correction.
  EXPECT_NEAR(shares[1], 3.0 / 7, 1e-6);
  EXPECT_NEAR(shares[2], 4.0 / 7, 1e-6);
  EXPECT_NEAR(shares[4], shares[2], 1e-6);
  EXPECT_DOUBLE_EQ(shares[0], 0);
  EXPECT_DOUBLE_EQ(shares[3], 1);
  EXPECT_NEAR(shares[5], 0, 1e-9);
  EXPECT_NEAR(shares[6], 0, 1e-9);
  EXPECT_NEAR(shares[7], 0, 1e-9);
}

}  // namespace
}  // namespace arscout::engine
