// Unit tests of the progress-log reader: the line variants `arscout
// reconstruct` prints, and the windows and percentiles built on them.
#include "progress_log.h"

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace ev = arscout::eval;

namespace {

const char* const kRegistered =
    "[12/400] 0011.jpg  registered  features 3000  pairs 9  inliers 812  "
    "reproj 0.310 px  geo  | decode 0.01 undistort 0.00 features 0.20 match "
    "0.80 pose 0.01 triang 0.01 ba 0.20 total 1.30 s";

TEST(ProgressLog, ReadsAPlainRegisteredLine) {
  const auto p = ev::parse_photo_line(kRegistered);
  ASSERT_TRUE(p);
  EXPECT_EQ(p->number, 12);
  EXPECT_EQ(p->total, 400);
  EXPECT_EQ(p->name, "0011.jpg");
  EXPECT_EQ(p->status, "registered");
  EXPECT_EQ(p->reason, "");
  EXPECT_EQ(p->features, 3000);
  EXPECT_EQ(p->pairs, 9);
  EXPECT_EQ(p->inliers, 812);
  EXPECT_DOUBLE_EQ(p->reproj_px, 0.310);
  EXPECT_TRUE(p->geo);
  EXPECT_FALSE(p->loop_closed);
  EXPECT_EQ(p->stage_s.size(), 8u);
  EXPECT_DOUBLE_EQ(p->stage_s.at("match"), 0.80);
  EXPECT_DOUBLE_EQ(p->increment_s(), 1.30);
  EXPECT_TRUE(p->also_registered.empty());
}

TEST(ProgressLog, ReadsAReasonWithParenthesesInside) {
  const auto p = ev::parse_photo_line(
      "[3/60] 0002.jpg  pending (too few matches (12 < 30))  features 2500  "
      "pairs 0  inliers 0  reproj 0.000 px  | decode 0.01 undistort 0.00 "
      "features 0.15 match 0.05 pose 0.00 triang 0.00 ba 0.00 total 0.21 s");
  ASSERT_TRUE(p);
  EXPECT_EQ(p->status, "pending");
  EXPECT_EQ(p->reason, "too few matches (12 < 30)");
  EXPECT_EQ(p->features, 2500);
  EXPECT_FALSE(p->geo);
  EXPECT_DOUBLE_EQ(p->increment_s(), 0.21);
}

TEST(ProgressLog, ReadsLoopClosedAndAlsoRegistered) {
  const auto p = ev::parse_photo_line(
      "[58/60] 0057.jpg  registered  features 3000  pairs 14  inliers 900  "
      "reproj 0.280 px  geo  loop closed  | decode 0.01 undistort 0.00 "
      "features 0.20 match 0.90 pose 0.01 triang 0.02 ba 0.70 total 1.84 s  "
      "(also registered: 0002.jpg 0003.jpg)");
  ASSERT_TRUE(p);
  EXPECT_TRUE(p->geo);
  EXPECT_TRUE(p->loop_closed);
  EXPECT_DOUBLE_EQ(p->increment_s(), 1.84);
  EXPECT_EQ(p->also_registered,
            (std::vector<std::string>{"0002.jpg", "0003.jpg"}));
}

TEST(ProgressLog, ARefusedInputHasNoIncrement) {
  const auto p =
      ev::parse_photo_line("[7/60] 0006.jpg  rejected (cannot decode image)");
  ASSERT_TRUE(p);
  EXPECT_EQ(p->status, "rejected");
  EXPECT_EQ(p->reason, "cannot decode image");
  EXPECT_TRUE(p->stage_s.empty());
  EXPECT_TRUE(std::isnan(p->increment_s()));
}

TEST(ProgressLog, ReadsRefineLines) {
  const auto gave_way = ev::parse_refine_line(
      "      refine: 120 images, 3 iterations, 1.95 s (given way)");
  ASSERT_TRUE(gave_way);
  EXPECT_EQ(gave_way->images, 120);
  EXPECT_EQ(gave_way->iterations, 3);
  EXPECT_DOUBLE_EQ(gave_way->seconds, 1.95);
  EXPECT_TRUE(gave_way->gave_way);
  const auto converged =
      ev::parse_refine_line("      refine: 60 images, 7 iterations, 0.40 s");
  ASSERT_TRUE(converged);
  EXPECT_FALSE(converged->gave_way);
  EXPECT_FALSE(ev::parse_refine_line(kRegistered));
  EXPECT_FALSE(
      ev::parse_photo_line("      refine: 60 images, 7 iterations, "
                           "0.40 s"));
}

TEST(ProgressLog, ReadsDenseLines) {
  const auto two = ev::parse_dense_line(
      "      dense: 2 new depth maps 0003.jpg 0004.jpg  (waiting: 1)  "
      "(covered by the key views: 1)  points 81234 (2 moved re-fused)  | "
      "sweep 1.52 filter 0.10 fusion 0.05 s");
  ASSERT_TRUE(two);
  EXPECT_EQ(two->new_depth_maps,
            (std::vector<std::string>{"0003.jpg", "0004.jpg"}));
  EXPECT_EQ(two->points, 81234);
  EXPECT_NEAR(two->seconds(), 1.67, 1e-12);
  const auto none = ev::parse_dense_line(
      "      dense: 0 new depth maps  points 900 (re-fused)  | sweep 0.00 "
      "filter 0.02 fusion 0.30 s");
  ASSERT_TRUE(none);
  EXPECT_TRUE(none->new_depth_maps.empty());
  EXPECT_DOUBLE_EQ(none->fusion_s, 0.30);
  EXPECT_FALSE(ev::parse_dense_line(kRegistered));
  EXPECT_THROW(ev::parse_dense_line("      dense: 2 new depth maps a.jpg"),
               std::runtime_error);
  std::istringstream log(
      "[1/2] 0000.jpg  pending (no pair yet)  features 10\n"
      "      dense: 1 new depth map 0000.jpg  points 10  | sweep 1.00 "
      "filter 0.25 fusion 0.25 s\n"
      "      dense: 1 new depth map 0001.jpg  points 20  | sweep 2.00 "
      "filter 0.00 fusion 0.50 s\n");
  const ev::ProgressLog parsed = ev::parse_progress_log(log);
  EXPECT_DOUBLE_EQ(parsed.dense_seconds(), 4.0);
  EXPECT_EQ(parsed.depth_map_ids(),
            (std::vector<std::string>{"0000.jpg", "0001.jpg"}));
}

TEST(ProgressLog, OtherLinesAreNotPhotoLines) {
  EXPECT_FALSE(ev::parse_photo_line("added 60 images in 12.00 s"));
  EXPECT_FALSE(ev::parse_photo_line("[2026-11-21 13:58:00.123] [warning] x"));
  EXPECT_FALSE(ev::parse_photo_line(""));
  EXPECT_THROW(ev::parse_photo_line("[1/2] 0000.jpg  exploded"),
               std::runtime_error);
  EXPECT_THROW(ev::parse_photo_line("[1/2] 0000.jpg  registered  | decode"),
               std::runtime_error);
}

TEST(ProgressLog, ReadsAWholeLogAndItsWindows) {
  std::stringstream log;
  for (int n = 1; n <= 4; ++n) {
    log << "[" << n << "/5] 000" << n - 1 << ".jpg  registered  features 10"
        << "  pairs 1  inliers 10  reproj 0.100 px  | decode 0.00 total " << n
        << ".00 s\n";
    if (n == 2) log << "      refine: 2 images, 3 iterations, 0.50 s\n";
    if (n == 3)
      log << "      waiting registered: 2 (a.jpg b.jpg), 0.41 s (given way)\n"
          << "      waiting registered: 1 (c.jpg), 0.20 s\n";
  }
  log << "[5/5] 0004.jpg  rejected (cannot decode image)\n"
      << "added 5 images in 10.50 s\n"
      << "      refine: 4 images, 2 iterations, 0.25 s\n"
      << "registered 4 images, 100 points, mean reprojection error 0.1 px\n";
  const ev::ProgressLog parsed = ev::parse_progress_log(log);
  EXPECT_EQ(parsed.photos.size(), 5u);
  ASSERT_EQ(parsed.refines.size(), 2u);
  EXPECT_EQ(parsed.refines[0].after_photo, 2);
  EXPECT_EQ(parsed.refines[1].after_photo, 5);
  EXPECT_DOUBLE_EQ(parsed.refine_seconds(), 0.75);
  EXPECT_EQ(parsed.registered, 4);
  EXPECT_EQ(parsed.waiting_registered, 3);
  EXPECT_EQ(ev::increments(parsed, 2, 5), (std::vector<double>{2, 3, 4}));
  EXPECT_TRUE(ev::increments(parsed, 6, 9).empty());
}

TEST(ProgressLog, ErrorsNameTheLine) {
  std::stringstream log("added 0 images\n[1/2] 0000.jpg  exploded\n");
  try {
    ev::parse_progress_log(log, "run.log");
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()).rfind("run.log:2: ", 0), 0u) << e.what();
  }
}

TEST(Percentile, InterpolatesBetweenOrderStatistics) {
  EXPECT_TRUE(std::isnan(ev::percentile({}, 0.5)));
  EXPECT_DOUBLE_EQ(ev::percentile({7}, 0.95), 7);
  EXPECT_DOUBLE_EQ(ev::percentile({4, 1, 3, 2}, 0.5), 2.5);
  EXPECT_DOUBLE_EQ(ev::percentile({4, 1, 3, 2}, 0), 1);
  EXPECT_DOUBLE_EQ(ev::percentile({4, 1, 3, 2}, 1), 4);
  std::vector<double> twenty;
  for (int i = 1; i <= 20; ++i) twenty.push_back(i);
  // Rank 0.95 * 19 = 18.05: between 19 and 20.
  EXPECT_NEAR(ev::percentile(twenty, 0.95), 19.05, 1e-12);
}

}  // namespace
