// Guided matching along epipolar lines (sfm/guided_matching.h) and the
// refinement's densification with the weaker corners (sfm/densify.cpp), on
// scenes with exact ground truth: registered at their true poses, each
// track's keypoints sharing one descriptor (with a little noise).
#include <algorithm>
#include <map>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "estimators/bundle_adjuster.h"
#include "sfm/guided_matching.h"
#include "sfm/mapper.h"
#include "synthetic_scene.h"

namespace arscout::engine {
namespace {

cv::Mat unit_row(std::mt19937& rng) {
  std::normal_distribution<float> component(0, 1);
  cv::Mat row(1, 128, CV_32F);
  for (int k = 0; k < 128; ++k) row.at<float>(k) = std::abs(component(rng));
  return row / cv::norm(row);
}

// Every observation's descriptor becomes its point's, plus noise, as one
// corner seen from nearby viewpoints gives.
void share_descriptors_along_tracks(Scene& scene, std::mt19937& rng) {
  std::normal_distribution<float> noise(0, 0.01f);
  for (const auto& [id, point] : scene.points) {
    const cv::Mat base = unit_row(rng);
    for (const Observation& obs : point.track) {
      cv::Mat row = base.clone();
      for (int k = 0; k < 128; ++k)
        row.at<float>(k) = std::abs(row.at<float>(k) + noise(rng));
      row /= cv::norm(row);
      row.copyTo(scene.images[obs.image].descriptors.row(obs.keypoint));
    }
  }
}

Scene shared_descriptor_scene(int images, int clutter, unsigned seed) {
  std::mt19937 rng(seed);
  synthetic::Layout layout;
  layout.images = images;
  layout.points = 600;
  const synthetic::Truth truth = synthetic::make_truth(layout, rng);
  Scene scene = synthetic::make_scene(truth, 0.2, clutter, rng);
  share_descriptors_along_tracks(scene, rng);
  return scene;
}

std::vector<int> all_keypoints(const SceneImage& image) {
  std::vector<int> all(image.keypoints.size());
  for (size_t k = 0; k < all.size(); ++k) all[k] = static_cast<int>(k);
  return all;
}

TEST(GuidedMatching, FindsTheTrueCorrespondencesAndNotTheCopiesOffTheLine) {
  Scene scene = shared_descriptor_scene(2, 200, 5);
  SceneImage& b = scene.images[1];
  // For every point both see, a copy of its corner in b 12 px below: the
  // same descriptor, but off the epipolar line.
  std::map<int, int64_t> copies;  // keypoint of b -> the point it copies
  for (const auto& [id, point] : scene.points) {
    if (point.track.size() < 2) continue;
    const int kb = point.track[1].keypoint;
    copies[static_cast<int>(b.keypoints.size())] = id;
    b.keypoints.push_back(b.keypoints[kb] + Eigen::Vector2d(0, 12));
    b.point_of.push_back(-1);
    cv::Mat grown;
    cv::vconcat(b.descriptors, b.descriptors.row(kb), grown);
    b.descriptors = grown;
  }
  const auto matches = guided_matches(
      scene.cameras[0], scene.images[0], all_keypoints(scene.images[0]),
      scene.cameras[0], b, all_keypoints(b), GuidedMatchOptions());
  int right = 0;
  for (const auto& [ka, kb] : matches) {
    EXPECT_EQ(copies.count(kb), 0u) << "a copy off the line was matched";
    const int64_t pa = scene.images[0].point_of[ka];
    right += pa >= 0 && pa == b.point_of[kb];
  }
  EXPECT_EQ(right, static_cast<int>(matches.size())) << "a wrong match";
  EXPECT_GE(right, static_cast<int>(0.95 * copies.size()));
}

// Drops every observation of a keypoint at or past `strong` (the corners an
// increment leaves out) and the points left with fewer than two; the
// matches of the remaining tracks between consecutive images become the
// verified pairs. Returns the observations dropped, keyed by (image,
// keypoint), with the true position of their point.
std::map<std::pair<int, int>, Eigen::Vector3d> keep_strong_only(Scene& scene,
                                                                int strong) {
  std::map<std::pair<int, int>, Eigen::Vector3d> dropped;
  std::vector<int64_t> ids;
  for (const auto& [id, point] : scene.points) ids.push_back(id);
  for (int64_t id : ids) {
    ScenePoint& point = scene.points.at(id);
    for (const Observation& obs : point.track) {
      if (obs.keypoint < strong) continue;
      dropped[{obs.image, obs.keypoint}] = point.xyz;
      scene.images[obs.image].point_of[obs.keypoint] = -1;
    }
    std::erase_if(point.track, [&](const Observation& obs) {
      return obs.keypoint >= strong;
    });
    if (point.track.size() < 2) {
      scene.remove_point(id);
      continue;
    }
    for (size_t i = 0; i + 1 < point.track.size(); ++i) {
      scene.pairs[{point.track[i].image, point.track[i + 1].image}]
          .matches.emplace_back(point.track[i].keypoint,
                                point.track[i + 1].keypoint);
    }
  }
  return dropped;
}

TEST(Densify, WeakCornersComeBackAtTheirTruePlaces) {
  Scene scene = shared_descriptor_scene(6, 100, 11);
  int fewest = static_cast<int>(scene.images[0].keypoints.size());
  for (const SceneImage& image : scene.images)
    fewest = std::min(fewest, static_cast<int>(image.keypoints.size()));
  ReconstructionOptions options;
  options.match_features = fewest / 2;
  const auto dropped = keep_strong_only(scene, options.match_features);
  ASSERT_GT(dropped.size(), 500u);
  const size_t points_before = scene.points.size();
  StageTimings timings;
  IncrementalMapper mapper(scene, options, timings);
  const int linked = mapper.densify_tracks({});
  EXPECT_GT(linked, 0);
  EXPECT_GT(scene.points.size(), points_before);
  std::vector<double> errors;  // of the points the dropped corners joined
  for (const auto& [where, truth] : dropped) {
    const int64_t point = scene.images[where.first].point_of[where.second];
    if (point >= 0)
      errors.push_back((scene.points.at(point).xyz - truth).norm());
  }
  // Matched only between the pairs the increments verified (consecutive
  // images here), a corner seen once in them stays out.
  EXPECT_GE(errors.size(), 0.8 * dropped.size());
  ASSERT_FALSE(errors.empty());
  std::sort(errors.begin(), errors.end());
  // 0.2 px of keypoint noise at 15 m and 12 degrees between neighbours
  // places a two-view point to about 2 cm; a wrong match lands metres off.
  EXPECT_LT(errors[errors.size() / 2], 0.03);
  EXPECT_LT(errors.back(), 0.25);
  EXPECT_EQ(mapper.densify_tracks({}), 0) << "each pair is densified once";
}

TEST(Densify, LocalAdjustmentLeavesTheWeakCornersOut) {
  Scene scene = shared_descriptor_scene(6, 0, 13);
  const int strong = static_cast<int>(scene.images[2].keypoints.size()) / 2;
  BundleOptions all;
  all.max_iterations = 1;
  BundleOptions strong_only = all;
  strong_only.strong_keypoints = strong;
  Scene copy = scene;
  const BundleReport with_all = adjust_bundle(copy, {2, 3}, false, all);
  copy = scene;
  const BundleReport with_strong =
      adjust_bundle(copy, {2, 3}, false, strong_only);
  EXPECT_GT(with_strong.points, 0);
  EXPECT_LT(with_strong.points, with_all.points);
}

}  // namespace
}  // namespace arscout::engine
