// `arscout reconstruct` on the real scenes, against their ground truth.
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <iostream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "model_eval.h"
#include "run_cli.h"
#include "test_stores.h"
#include "tool_process.h"

namespace arscout {
namespace {

using testing::run_cli;
using testing::ToolProcess;

struct StrechaRun {
  eval::PoseComparison poses;
  double geo_median_m = 0;
  int geo_matched = 0;
};

StrechaRun reconstruct_strecha(const std::string& scene,
                               const std::string& out) {
  const std::string dir = scene + "/images";
  run_cli({"reconstruct", "--images", dir, "--gps-csv", scene + "/gps.csv",
           "--camera", dir + "/K.txt", "--out", out},
          out + ".log");
  StrechaRun run;
  run.poses = eval::compare_to_ground_truth(
      eval::read_colmap_images_txt(out + "/sparse/images.txt"),
      eval::read_strecha_ground_truth(scene + "/gt_dense_cameras"));
  run.geo_median_m = eval::median_geo_distance(
      eval::read_geo_csv(out + "/cameras_geo.csv"),
      eval::read_geo_csv(scene + "/gps_truth.csv"), &run.geo_matched);
  return run;
}

TEST(ReconstructAcceptance, FountainP11MeetsTheAccuracyTargets) {
  std::string scene;
  ARSCOUT_SHARED_DATA_OR_SKIP(scene, "strecha/fountain-P11");
  const std::string out = testing::make_temp_dir("fountain") + "/out";
  const StrechaRun run = reconstruct_strecha(scene, out);
  EXPECT_EQ(run.poses.matched, 11);
  EXPECT_LE(run.poses.median_centre_error, 0.005);
  EXPECT_LE(run.poses.median_rotation_error_deg, 0.1);
  EXPECT_EQ(run.geo_matched, 11);
  // The raw fixes are off by about 2.5 m.
  EXPECT_LE(run.geo_median_m, 1.0);
  EXPECT_TRUE(std::filesystem::file_size(out + "/sparse.ply") > 1000);

  // `arscout render`: the model drawn from 0005.jpg's camera looks like the
  // photo where points land (their colours came from the photos), and an
  // orbit view is not blank.
  cv::Mat photo = cv::imread(scene + "/images/0005.jpg");
  cv::resize(photo, photo, cv::Size(768, 512), 0, 0, cv::INTER_AREA);
  cv::Mat grey_photo;
  cv::cvtColor(photo, grey_photo, cv::COLOR_BGR2GRAY);
  // Normalised cross-correlation of the drawing from `view` with photo
  // 0005 over the pixels it covers, and how many those are.
  auto compare = [&](const std::string& view, int* covered_px) {
    const std::string png = out + "/view-" + view + ".png";
    run_cli({"render", "--model", out, "--view", view, "--width", "768",
             "--radius", "1", "-o", png},
            out + "/render.log");
    const cv::Mat drawn = cv::imread(png);
    EXPECT_EQ(drawn.size(), grey_photo.size());
    cv::Mat grey_drawn;
    cv::cvtColor(drawn, grey_drawn, cv::COLOR_BGR2GRAY);
    const cv::Mat covered = grey_drawn > 0;
    *covered_px = cv::countNonZero(covered);
    cv::Scalar m_drawn, s_drawn, m_photo, s_photo;
    cv::meanStdDev(grey_drawn, m_drawn, s_drawn, covered);
    cv::meanStdDev(grey_photo, m_photo, s_photo, covered);
    cv::Mat a, b, product;
    grey_drawn.convertTo(a, CV_64F, 1, -m_drawn[0]);
    grey_photo.convertTo(b, CV_64F, 1, -m_photo[0]);
    cv::multiply(a, b, product);
    return cv::mean(product, covered)[0] / (s_drawn[0] * s_photo[0]);
  };
  int covered_px = 0, other_px = 0;
  const double same = compare("0005.jpg", &covered_px);
  // A control: the cloud drawn from another camera does not match 0005.
  const double other = compare("0000.jpg", &other_px);
  std::cout << "render --view: " << covered_px << " pixels covered, "
            << "correlation with the photo " << same << " (drawn from "
            << "0000.jpg's camera: " << other << ")" << std::endl;
  EXPECT_GT(covered_px, 5000);
  EXPECT_GT(same, 0.4);
  EXPECT_LT(other, same - 0.3);
  run_cli({"render", "--model", out, "--orbit", "--width", "640", "--height",
           "480", "-o", out + "/orbit.png"},
          out + "/render.log");
  const cv::Mat orbit = cv::imread(out + "/orbit.png", cv::IMREAD_GRAYSCALE);
  ASSERT_EQ(orbit.size(), cv::Size(640, 480));
  cv::Scalar mean, stddev;
  cv::meanStdDev(orbit, mean, stddev);
  EXPECT_GT(stddev[0], 5);
}

// entry-P10 meets the rotation and GPS targets; its median centre error
// (5.9 mm with the defaults; 4.8-8.2 mm over 13 feature and resolution
// settings, docs/engine.md) is above the 5 mm, a point reported as
// blocked. This guards against regressions meanwhile.
TEST(ReconstructAcceptance, EntryP10RegistersAllWithinTolerance) {
  std::string scene;
  ARSCOUT_SHARED_DATA_OR_SKIP(scene, "strecha/entry-P10");
  const std::string out = testing::make_temp_dir("entry") + "/out";
  const StrechaRun run = reconstruct_strecha(scene, out);
  EXPECT_EQ(run.poses.matched, 10);
  EXPECT_LE(run.poses.median_centre_error, 0.008);
  EXPECT_LE(run.poses.median_rotation_error_deg, 0.1);
  EXPECT_LE(run.geo_median_m, 1.0);
}

// The Middlebury ring, without GPS, with the K of its parameter file:
// some photos are upside down and the file order is not the ring order.
TEST(ReconstructAcceptance, TempleSparseRingRegistersAllWithinOnePercent) {
  std::string scene;
  ARSCOUT_SHARED_DATA_OR_SKIP(scene, "middlebury/templeSparseRing");
  const std::string work = testing::make_temp_dir("temple");
  std::ifstream par(scene + "/templeSR_par.txt");
  std::string count, name;
  double k[9];
  par >> count >> name;
  for (double& v : k) par >> v;
  {
    std::ofstream out(work + "/K.txt");
    for (int i = 0; i < 9; ++i) out << k[i] << (i % 3 == 2 ? '\n' : ' ');
  }
  run_cli({"reconstruct", "--images", scene, "--camera", work + "/K.txt",
           "--out", work + "/out"},
          work + "/out.log");
  const auto truth = eval::read_middlebury_par(scene + "/templeSR_par.txt");
  const auto poses = eval::compare_to_ground_truth(
      eval::read_colmap_images_txt(work + "/out/sparse/images.txt"), truth);
  EXPECT_EQ(poses.matched, 16);
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const auto& [n, pose] : truth) centroid += pose.centre();
  centroid /= truth.size();
  double radius = 0;
  for (const auto& [n, pose] : truth)
    radius += (pose.centre() - centroid).norm();
  radius /= truth.size();
  EXPECT_LE(poses.median_centre_error, 0.01 * radius)
      << "ring radius " << radius;
}

// lund: phone photos with EXIF GPS and focal length, no calibration.
TEST(ReconstructAcceptance, LundRegistersMostPhotosWithSmallErrors) {
  std::string scene;
  ARSCOUT_SHARED_DATA_OR_SKIP(scene, "opensfm/lund");
  const std::string out = testing::make_temp_dir("lund") + "/out";
  run_cli({"reconstruct", "--images", scene + "/images", "--out", out},
          out + ".log");
  const auto images = eval::read_colmap_images_txt(out + "/sparse/images.txt");
  EXPECT_GE(images.size(), 25u);
  double error_sum = 0, observations = 0;
  for (const auto& point :
       eval::read_colmap_points3d_txt(out + "/sparse/points3D.txt")) {
    error_sum += point.error * point.track_length;
    observations += point.track_length;
  }
  ASSERT_GT(observations, 0);
  EXPECT_LE(error_sum / observations, 1.5) << "mean reprojection error, pixels";
  EXPECT_EQ(eval::read_geo_csv(out + "/cameras_geo.csv").size(), images.size());
}

// Saving the state after 6 photos and resuming in a new process gives the
// model an uninterrupted deterministic run gives.
TEST(ReconstructAcceptance, ResumedRunEqualsUninterruptedRun) {
  std::string scene;
  ARSCOUT_SHARED_DATA_OR_SKIP(scene, "strecha/fountain-P11");
  const std::string work = testing::make_temp_dir("resume");
  const std::vector<std::string> common = {
      "reconstruct",           "--images",
      scene + "/images",       "--gps-csv",
      scene + "/gps.csv",      "--camera",
      scene + "/images/K.txt", "--deterministic"};
  auto with = [&](std::vector<std::string> extra) {
    std::vector<std::string> args = common;
    args.insert(args.end(), extra.begin(), extra.end());
    return args;
  };
  run_cli(with({"--out", work + "/whole"}), work + "/whole.log");
  run_cli(with({"--out", work + "/first", "--limit", "6", "--save-state",
                work + "/state.bin"}),
          work + "/first.log");
  run_cli(with({"--out", work + "/rest", "--resume", work + "/state.bin"}),
          work + "/rest.log");
  const auto whole =
      eval::read_colmap_images_txt(work + "/whole/sparse/images.txt");
  const auto resumed =
      eval::read_colmap_images_txt(work + "/rest/sparse/images.txt");
  ASSERT_EQ(whole.size(), 11u);
  ASSERT_EQ(resumed.size(), whole.size());
  for (const auto& [name, pose] : whole) {
    const auto it = resumed.find(name);
    ASSERT_NE(it, resumed.end()) << name;
    const double scale = std::max(1.0, pose.t.norm());
    EXPECT_LE((it->second.t - pose.t).norm() / scale, 1e-6) << name;
    EXPECT_LE((it->second.R - pose.R).norm(), 1e-6) << name;
  }
}

}  // namespace
}  // namespace arscout
