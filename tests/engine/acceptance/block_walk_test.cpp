// `arscout reconstruct` on a short synthetic scouting walk round a city
// block (`arscout render-site --scene block`): 60 photos of 640 x 480 with
// exact poses and noisy GPS, so it needs no ../shared/data and runs in CI's
// default build (label engine-synthetic, a few minutes on 2 cores). The
// small brother of bench/scale_bench (400 photos): registration, accuracy
// after a similarity fit, geo-registration against the noise-free fixes,
// and an increment cost that stays flat along the walk.
#include <cmath>
#include <filesystem>
#include <iostream>
#include <string>

#include <gtest/gtest.h>

#include "model_eval.h"
#include "progress_log.h"
#include "run_cli.h"
#include "test_stores.h"

namespace arscout {
namespace {

using testing::run_cli;

constexpr int kViews = 60;

TEST(BlockWalk, SixtyPhotosRegisterAccuratelyAtAFlatIncrementCost) {
  const std::string work = testing::make_temp_dir("block-walk");
  // Removed when the test passes; kept (site/, out/, *.log) otherwise.
  std::cout << "block walk in " << work << std::endl;
  const std::string site = work + "/site";
  const std::string out = work + "/out";
  run_cli({"render-site", "--scene", "block", "--views", std::to_string(kViews),
           "--width", "640", "--height", "480", "--seed", "11", "--out", site},
          work + "/render.log");
  if (HasFatalFailure()) return;
  run_cli({"reconstruct", "--images", site + "/images", "--gps-csv",
           site + "/gps.csv", "--camera", site + "/images/K.txt", "--out", out},
          work + "/reconstruct.log");
  if (HasFatalFailure()) return;

  // The increments first: they mean something even when the model does not.
  const eval::ProgressLog log =
      eval::read_progress_log(work + "/reconstruct.log");
  const double p95_early = eval::percentile(eval::increments(log, 11, 30), .95);
  const double p95_late = eval::percentile(eval::increments(log, 41, 60), .95);
  std::cout << "block walk: increment p95 photos 11-30 " << p95_early
            << " s, 41-60 " << p95_late << " s; refine " << log.refine_seconds()
            << " s" << std::endl;
  EXPECT_EQ(log.photos.size(), static_cast<std::size_t>(kViews));
  // A flat increment cost, as a ratio within the run and never an absolute
  // time: CI machines differ and are shared. The factor is 2.0 rather than
  // the 1.25 bench/scale_bench asks of 400 photos because the windows here
  // hold 20 photos each, so their p95 is close to their maximum, and one
  // photo slowed by a neighbour on a shared 2-core machine moves it a lot.
  EXPECT_FALSE(std::isnan(p95_early) || std::isnan(p95_late));
  EXPECT_LE(p95_late, 2.0 * p95_early);

  const auto estimated =
      eval::read_colmap_images_txt(out + "/sparse/images.txt");
  EXPECT_GE(estimated.size(), static_cast<std::size_t>(kViews - 2));
  ASSERT_GE(estimated.size(), 3u) << "the similarity fit needs three cameras";
  const auto poses = eval::compare_to_ground_truth(
      estimated, eval::read_strecha_ground_truth(site + "/gt_dense_cameras"));
  int geo_matched = 0;
  const double geo_median_m = eval::median_geo_distance(
      eval::read_geo_csv(out + "/cameras_geo.csv"),
      eval::read_geo_csv(site + "/gps_truth.csv"), &geo_matched);
  std::cout << "block walk: " << poses.matched << "/" << kViews
            << " registered, centre error median " << poses.median_centre_error
            << " m, max " << poses.max_centre_error << " m; geo median "
            << geo_median_m << " m over " << geo_matched << std::endl;
  EXPECT_GE(poses.matched, kViews - 2);
  // The scene is in metres: issue 17's targets, median 0.02 m and max
  // 0.10 m after the similarity fit (measured 2026-11-24: 0.0076 m and
  // 0.035 m). A photo that registers in the mirror minimum of a wall's
  // planar pose ambiguity (17 degrees and 1.3 m off, before SQPnP) fails the
  // max on its own.
  EXPECT_LE(poses.median_centre_error, 0.02);
  EXPECT_LE(poses.max_centre_error, 0.10);
  // The fixes are off by 1.5 m per horizontal axis and 3 m vertically.
  EXPECT_GE(geo_matched, kViews - 2);
  EXPECT_LE(geo_median_m, 1.0);

  if (!HasFailure()) std::filesystem::remove_all(work);
}

}  // namespace
}  // namespace arscout
