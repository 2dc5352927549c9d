// Replay regression on the other ../shared/data scenes (docs/sessions.md):
// each session was recorded by its record_session.sh fixture (a real scout
// uploading the scene's photos to a real server), is replayed into an empty
// store with a deterministic engine following it, and must drive the engine
// to a model with the expected statistics. A failure prints the whole table,
// expected against got.
#include <chrono>
#include <iostream>

#include <gtest/gtest.h>

#include "replay_support.h"
#include "test_stores.h"

namespace arscout {
namespace {

using replay::Row;

// Where the fixtures leave their sessions: ARSCOUT_REPLAY_SESSIONS/NAME/.
std::string session_of(const std::string& name) {
  return replay::recorded_session(
      std::string(ARSCOUT_REPLAY_SESSIONS) + "/" + name, name);
}

// entry-P10: ten 3072x2048 photos with their calibration and simulated
// fixes (gps.csv, 1.5 m noise per horizontal axis), exact ground truth.
TEST(ReplayRegression, EntryP10SessionDrivesTheEngineToTheExpectedModel) {
  std::string scene;
  ARSCOUT_SHARED_DATA_OR_SKIP(scene, "strecha/entry-P10");
  const std::string session = session_of("entry-P10");
  if (session.empty()) GTEST_SKIP() << "no recorded session";
  const std::chrono::seconds timeout{300};
  const replay::Replayed r = replay::replay_deterministically(session, timeout);
  ASSERT_TRUE(r.model) << "no finished model within " << timeout.count()
                       << " s";

  const db::Json& stats = r.model->attrs.at("statistics");
  const eval::PoseComparison truth = eval::compare_to_ground_truth(
      replay::model_poses(r.model->attrs),
      eval::read_strecha_ground_truth(scene + "/gt_dense_cameras"));
  int geo_matched = 0;
  const double geo_m = eval::median_geo_distance(
      replay::model_positions(r.model->attrs),
      eval::read_geo_csv(scene + "/gps_truth.csv"), &geo_matched);
  replay::expect_rows_within({
      {"captures replayed", double(r.summary.captures), 10, 10},
      {"cameras replayed", double(r.summary.cameras), 1, 1},
      {"inputs refused", double(r.summary.failed), 0, 0},
      {"sites", double(r.sites), 1, 1},
      {"registered", stats.value("registered", 0.0), 10, 10},
      {"rejected", stats.value("rejected", 0.0), 0, 0},
      // `arscout reconstruct` gets 5.9 mm (4.8-8.2 mm over settings,
      // tests/engine/acceptance) and the acceptance bound is 8 mm.
      {"median centre error vs truth, mm", 1000 * truth.median_centre_error, 0,
       8},
      // 0.085 deg measured; the 0.1 deg target is the acceptance tests'.
      {"median rotation error vs truth, deg", truth.median_rotation_error_deg,
       0, 0.12},
      {"cameras geo-registered", double(geo_matched), 10, 10},
      {"median geo error vs true position, m", geo_m, 0, 1.0},
      // Measured: 4626 sparse, 193 198 dense points, the same on every
      // deterministic replay (198 149 before the weak depths and the
      // triangulation floor, docs/dense.md); 10% as for the fountain. (281 192
      // dense while the voxel edge kept the scale of the first, three-fix
      // model; it now follows the model's scale, docs/dense.md.)
      {"sparse points", stats.value("sparse_points", 0.0), 4110, 5030},
      {"dense points", replay::dense_point_count(*r.store, *r.model), 178000,
       218000},
  });
}

// lund: 29 1024x768 phone photos of a 170 m street walk, EXIF GPS (5-10 m
// error) and EXIF focal length, no calibration and no ground truth: the
// figures are how many photos register, how well the model explains its
// observations, and how well its geo-registration agrees with the fixes.
TEST(ReplayRegression, LundSessionDrivesTheEngineToTheExpectedModel) {
  std::string scene;
  ARSCOUT_SHARED_DATA_OR_SKIP(scene, "opensfm/lund");
  const std::string session = session_of("lund");
  if (session.empty()) GTEST_SKIP() << "no recorded session";
  // 40 s measured; 68-130 s when it replayed at 4x on a busy machine.
  const std::chrono::seconds timeout{450};
  const replay::Replayed r = replay::replay_deterministically(session, timeout);
  ASSERT_TRUE(r.model) << "no finished model within " << timeout.count()
                       << " s";

  const db::Json& stats = r.model->attrs.at("statistics");
  const auto positions = replay::model_positions(r.model->attrs);
  replay::expect_rows_within({
      {"captures replayed", double(r.summary.captures), 29, 29},
      {"inputs refused", double(r.summary.failed), 0, 0},
      {"sites", double(r.sites), 1, 1},
      // All 29 register on replay; `arscout reconstruct` is held to 25.
      {"registered", stats.value("registered", 0.0), 27, 29},
      {"geo-registered", double(r.model->attrs.value("geo_registered", false)),
       1, 1},
      {"cameras placed on the globe", double(positions.size()), 27, 29},
      // 0.41 px measured; `arscout reconstruct` is held to 1.5 px.
      {"mean reprojection error, px", stats.value("mean_reprojection_px", 0.0),
       0, 1.0},
      // 3.7 m measured, the fixes' own error; a wrong scale, axis or frame
      // puts the cameras tens of metres or more from them.
      {"median horizontal model-GPS distance, m",
       replay::median_horizontal_distance(positions,
                                          replay::capture_fixes(*r.store)),
       0, 6},
      // Measured: 1789 sparse, 65 860 dense points, the same on every
      // deterministic replay (4500 corners, 3000 matched, the refinement's
      // loss at half a keypoint deviation; 81 815 at 3000 corners and 1.5
      // deviations, 67 122 and 66 091 with either change alone). Over the
      // model changes below the count has stood at two levels, 64-67k and
      // 79-88k, with the same registered walk: the voxel edge follows the
      // scale the fixes give, and is adopted anew only when it moves by
      // more than a tenth (docs/dense.md). The band takes both levels, 10%
      // beyond them. (Earlier: 1651 and 81 815; 1657 and 87 611
      // before the homography's poses were scored against RANSAC's,
      // docs/engine.md, "Planar scenes": the model-GPS distance moved from
      // 3.35 to 3.43 m and the voxel edge with the scale; 65 843 before the
      // matcher's 12-bit dot products and the adjustments' tolerances: the
      // model-GPS distance fell from 3.6 to 3.35 m, the scale the fixes
      // give moved, and the voxel edge with it; 76 118 dense before
      // keypoints were refined along their tracks, docs/engine.md, 81 934
      // with 17 px patches: the residuals fall, so the fixes weigh
      // differently against them and the scale they give moves, and the
      // voxel edge with it; 64 024 before
      // the adjustment weighed features by their own deviation against
      // the fixes, docs/engine.md: the model, whose scale only the fixes
      // give, changed with it; 79 426 while the voxel edge kept the scale
      // of the first model, docs/dense.md.)
      {"sparse points", stats.value("sparse_points", 0.0), 1520, 1860},
      // 18 825 dense points with the weak depths and the triangulation
      // floor (docs/dense.md); since the last outlier pass ("Isolated
      // points"): 18 184 (23 690 with the ground sweep, "Ground", whose
      // clip took the depths below the ground's last plane; 29 631 with
      // the free-space and sky filters alone, before which half the cloud
      // was sky, points past the ground and their like). Since descriptors
      // are kept to 1/65536 (issue 37): 31 509. The matches moved a little
      // (1776 sparse points, model-GPS 3.32 m), the first depth map's
      // median depth with them, and the voxel edge it sets is 0.140 model
      // units against 0.167 (docs/dense.md, "fusion": the edge is adopted
      // anew only when it moves by a tenth): a sixth finer edge, 1.67
      // times the points over the same registered walk. The band takes
      // both levels: 10% below the coarse one, 10% above the fine one.
      {"dense points", replay::dense_point_count(*r.store, *r.model), 16400,
       34700},
  });
}

}  // namespace
}  // namespace arscout
