// IncrementalMapper::join_tracks on a scene with exact ground truth whose
// tracks were cut in two, as a merge of two components leaves the points
// of one place on either side of the seam.
#include <algorithm>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "sfm/mapper.h"
#include "synthetic_scene.h"

namespace arscout::engine {
namespace {

// Every point of `scene` whose track has at least two observations in
// images below `seam` and two at or above it becomes two points, one per
// side; the matches between consecutive images of each original track
// become the scene's verified pairs. Returns the points cut.
int cut_tracks_at(Scene& scene, int seam) {
  std::vector<int64_t> ids;
  for (const auto& [id, point] : scene.points) ids.push_back(id);
  int cut = 0;
  for (int64_t id : ids) {
    std::vector<Observation> track = scene.points.at(id).track;
    std::sort(track.begin(), track.end(),
              [](const auto& a, const auto& b) { return a.image < b.image; });
    for (size_t i = 0; i + 1 < track.size(); ++i) {
      scene.pairs[{track[i].image, track[i + 1].image}].matches.emplace_back(
          track[i].keypoint, track[i + 1].keypoint);
    }
    std::vector<Observation> early, late;
    for (const Observation& obs : track)
      (obs.image < seam ? early : late).push_back(obs);
    if (early.size() < 2 || late.size() < 2) continue;
    scene.points.at(id).track = early;
    scene.add_point(scene.points.at(id).xyz, late);
    ++cut;
  }
  return cut;
}

// `images` registered at their true poses, keypoints 0.3 px off, full
// tracks (synthetic_scene.h).
Scene registered_scene(int images, unsigned seed) {
  std::mt19937 rng(seed);
  synthetic::Layout layout;
  layout.images = images;
  const synthetic::Truth truth = synthetic::make_truth(layout, rng);
  return synthetic::make_scene(truth, 0.3, 0, rng);
}

TEST(JoinTracks, PointsCutAtASeamBecomeOneAgain) {
  Scene scene = registered_scene(8, 17);
  const size_t points_before = scene.points.size();
  const int cut = cut_tracks_at(scene, 4);
  ASSERT_GT(cut, 100);
  ASSERT_EQ(scene.points.size(), points_before + cut);
  ReconstructionOptions options;
  StageTimings timings;
  IncrementalMapper mapper(scene, options, timings);
  // Each cut point is rejoined through the one match that crosses the
  // seam between its consecutive images.
  EXPECT_EQ(mapper.join_tracks({}), cut);
  EXPECT_EQ(scene.points.size(), points_before);
  EXPECT_EQ(mapper.join_tracks({}), 0) << "a second pass finds nothing";
}

// The keypoint of `point` in `image`, or -1.
int keypoint_in(const ScenePoint& point, int image) {
  for (const Observation& obs : point.track)
    if (obs.image == image) return obs.keypoint;
  return -1;
}

// Drops `point`'s observations in images [first, last].
void drop_observations(Scene& scene, int64_t point, int first, int last) {
  auto& track = scene.points.at(point).track;
  for (const Observation& obs : track)
    if (obs.image >= first && obs.image <= last)
      scene.images[obs.image].point_of[obs.keypoint] = -1;
  std::erase_if(track, [&](const Observation& obs) {
    return obs.image >= first && obs.image <= last;
  });
}

// A match that says two different places are one joins nothing: no
// position explains both tracks. An observation the model lost (filtered
// as an outlier earlier) comes back through its match when it fits.
TEST(JoinTracks, AFalseMatchStaysApartALostObservationComesBack) {
  Scene scene = registered_scene(6, 23);
  // Two points every image sees, 3 m or more apart: p kept in images 0-2,
  // q in images 3-5, and a false match between p in image 2 and q in 3.
  int64_t p = -1, q = -1;
  for (const auto& [id, point] : scene.points) {
    if (point.track.size() < 6) continue;
    if (p < 0) {
      p = id;
    } else if ((point.xyz - scene.points.at(p).xyz).norm() > 3) {
      q = id;
      break;
    }
  }
  ASSERT_GE(q, 0);
  const int kp1 = keypoint_in(scene.points.at(p), 1);
  const int kp2 = keypoint_in(scene.points.at(p), 2);
  const int kp4 = keypoint_in(scene.points.at(p), 4);
  const int kq3 = keypoint_in(scene.points.at(q), 3);
  drop_observations(scene, p, 3, 5);
  drop_observations(scene, q, 0, 2);
  scene.pairs[{2, 3}].matches.emplace_back(kp2, kq3);  // the false match
  // p's observations in images 1 and 4, lost, named again by matches with
  // image 2: they fit p and come back.
  drop_observations(scene, p, 1, 1);
  scene.pairs[{1, 2}].matches.emplace_back(kp1, kp2);
  scene.pairs[{2, 4}].matches.emplace_back(kp2, kp4);
  const size_t points_before = scene.points.size();
  ReconstructionOptions options;
  StageTimings timings;
  IncrementalMapper mapper(scene, options, timings);
  EXPECT_EQ(mapper.join_tracks({}), 2);
  EXPECT_EQ(scene.points.size(), points_before);
  EXPECT_EQ(scene.images[1].point_of[kp1], p);
  EXPECT_EQ(scene.images[4].point_of[kp4], p);
  EXPECT_EQ(scene.images[3].point_of[kq3], q);
  EXPECT_EQ(scene.points.at(q).track.size(), 3u);
}

}  // namespace
}  // namespace arscout::engine
