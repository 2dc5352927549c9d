// New coverage (engine/src/dense/view_coverage.h): the share of a view's
// scene cells that held depth maps measure, on exact geometry.
#include "dense/view_coverage.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

namespace arscout::engine {
namespace {

constexpr int kWidth = 640, kHeight = 480;
constexpr double kFocal = 500;

CameraIntrinsics photo_camera() {
  CameraIntrinsics camera;
  camera.width = kWidth;
  camera.height = kHeight;
  camera.fx = camera.fy = kFocal;
  camera.cx = kWidth / 2.0;
  camera.cy = kHeight / 2.0;
  return camera;
}

// A wall 10 m ahead of a camera at (x, 0, 0) looking down +z, measured
// everywhere (at the photo's own resolution).
DepthMap wall_map(double x) {
  DepthMap map;
  map.depth = cv::Mat(kHeight, kWidth, CV_32F, cv::Scalar(10.0f));
  map.K << kFocal, 0, kWidth / 2.0, 0, kFocal, kHeight / 2.0, 0, 0, 1;
  map.t = Eigen::Vector3d(-x, 0, 0);  // world-to-camera: X_c = X - C
  return map;
}

// Keypoints on every cell of the photo.
std::vector<std::array<double, 2>> keypoints_everywhere() {
  std::vector<std::array<double, 2>> keypoints;
  for (int y = 5; y < kHeight; y += 20)
    for (int x = 5; x < kWidth; x += 20)
      keypoints.push_back({double(x), double(y)});
  return keypoints;
}

double share_of(const std::vector<std::array<double, 2>>& keypoints,
                const std::vector<const DepthMap*>& maps,
                const Eigen::Matrix3d& R = Eigen::Matrix3d::Identity()) {
  return measured_share(photo_camera(), R, Eigen::Vector3d::Zero(), keypoints,
                        maps);
}

TEST(ViewCoverage, TwoMapsMeasureWhatOneAloneDoesNot) {
  // The cloud keeps a depth only where two maps agree: one map from the
  // very same place measures nothing yet, a second one everything.
  const DepthMap here = wall_map(0), near = wall_map(0.1);
  EXPECT_DOUBLE_EQ(share_of(keypoints_everywhere(), {&here}), 0.0);
  EXPECT_DOUBLE_EQ(share_of(keypoints_everywhere(), {&here, &near}), 1.0);
}

TEST(ViewCoverage, MapsHalfAPictureAsideMeasureHalf) {
  // The picture spans 640 / 500 * 10 = 12.8 m of the wall: a camera 6.4 m
  // to the side sees half of it.
  const DepthMap here = wall_map(0), right = wall_map(6.4),
                 left = wall_map(-6.4);
  EXPECT_NEAR(share_of(keypoints_everywhere(), {&here, &right}), 0.5, 1.0 / 16);
  EXPECT_DOUBLE_EQ(share_of(keypoints_everywhere(), {&here, &right, &left}),
                   1.0);
}

TEST(ViewCoverage, OnlyCellsWhereTheViewSeesTheSceneCount) {
  // The view's keypoints all lie in its left half, which the maps measure:
  // the right half (sky, say) asks for nothing.
  std::vector<std::array<double, 2>> left_half;
  for (const auto& k : keypoints_everywhere())
    if (k[0] < kWidth / 2.0) left_half.push_back(k);
  const DepthMap here = wall_map(0), left = wall_map(-6.4);
  EXPECT_DOUBLE_EQ(share_of(left_half, {&here, &left}), 1.0);
  // Nothing measured behind the camera, nothing asked without keypoints.
  const Eigen::Matrix3d turned =
      Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitY()).toRotationMatrix();
  EXPECT_DOUBLE_EQ(share_of(keypoints_everywhere(), {&here, &left}, turned),
                   0.0);
  EXPECT_DOUBLE_EQ(share_of({}, {&here, &left}), 0.0);
}

}  // namespace
}  // namespace arscout::engine
