// Unit tests of the evaluation library: synthetic data with known answers,
// plus the real ground truth in ../shared/data when it is there.
#include "model_eval.h"

#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <numbers>
#include <random>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

namespace fs = std::filesystem;
using arscout::eval::Pose;
using Eigen::Matrix3d;
using Eigen::Vector2d;
using Eigen::Vector3d;
namespace ev = arscout::eval;

namespace {

// ---- Synthetic data ----

Matrix3d random_rotation(std::mt19937& rng) {
  std::normal_distribution<double> n;
  // One draw per statement: argument order is unspecified.
  const double w = n(rng), x = n(rng), y = n(rng), z = n(rng);
  Eigen::Quaterniond q(w, x, y, z);
  return q.normalized().toRotationMatrix();
}

Vector3d random_vector(std::mt19937& rng, double sigma) {
  std::normal_distribution<double> n(0, sigma);
  const double x = n(rng), y = n(rng), z = n(rng);
  return Vector3d(x, y, z);
}

Matrix3d rotation_about(const Vector3d& axis, double degrees) {
  return Eigen::AngleAxisd(degrees * std::numbers::pi / 180, axis.normalized())
      .toRotationMatrix();
}

// `count` cameras on a horizontal ring of `radius` round the origin, each
// looking at the origin with a random roll, like a turntable capture.
std::map<std::string, Pose> ring_of_cameras(int count, double radius,
                                            std::mt19937& rng) {
  std::uniform_real_distribution<double> roll(-20, 20);
  std::map<std::string, Pose> poses;
  for (int i = 0; i < count; ++i) {
    const double a = 2 * std::numbers::pi * i / count;
    const Vector3d C(radius * std::cos(a), radius * std::sin(a), 0);
    const Vector3d z = -C.normalized();  // optical axis, to the origin
    const Vector3d x = Vector3d::UnitZ().cross(z).normalized();
    Matrix3d cam_to_world;
    cam_to_world << x, z.cross(x), z;
    const Matrix3d R =
        rotation_about(Vector3d::UnitZ(), roll(rng)) * cam_to_world.transpose();
    char name[16];
    std::snprintf(name, sizeof name, "%04d.jpg", i);
    poses[name] = Pose::from_centre(name, R, C);
  }
  return poses;
}

ev::Similarity random_similarity(std::mt19937& rng) {
  return {0.37, random_rotation(rng), random_vector(rng, 5)};
}

std::map<std::string, Pose> transformed(const std::map<std::string, Pose>& in,
                                        const ev::Similarity& sim) {
  std::map<std::string, Pose> out;
  for (const auto& [name, pose] : in) out[name] = ev::transform_pose(sim, pose);
  return out;
}

ev::Similarity inverse(const ev::Similarity& s) {
  return {1 / s.scale, s.R.transpose(), -s.R.transpose() * s.t / s.scale};
}

// ---- Files ----

// A fresh folder per test, removed afterwards.
class TempDirTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("model_eval_test_" + std::to_string(::getpid()) + "_" +
            info->test_suite_name() + "_" + info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string write(const std::string& name, const std::string& text) {
    const fs::path path = dir_ / name;
    fs::create_directories(path.parent_path());
    std::ofstream(path) << text;
    return path.string();
  }

  fs::path dir_;
};

// COLMAP's images.txt layout; every other image gets a non-empty POINTS2D
// line, and the last one has none at all (as if the writer dropped it).
std::string images_txt(const std::map<std::string, Pose>& poses) {
  std::ostringstream out;
  out.precision(17);
  out << "# Image list with two lines of data per image:\n"
      << "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n"
      << "#   POINTS2D[] as (X, Y, POINT3D_ID)\n";
  int id = 1;
  for (const auto& [name, pose] : poses) {
    const Eigen::Quaterniond q(pose.R);
    out << id << ' ' << q.w() << ' ' << q.x() << ' ' << q.y() << ' ' << q.z()
        << ' ' << pose.t.x() << ' ' << pose.t.y() << ' ' << pose.t.z() << " 1 "
        << name << "\n";
    if (id == static_cast<int>(poses.size())) break;
    out << (id % 2 ? "10.5 20.25 7 30 40 -1\n" : "\n");
    ++id;
  }
  return out.str();
}

// A Strecha .camera file, laid out as in ../shared/data/README.md.
std::string strecha_camera(const Pose& pose) {
  const Matrix3d cam_to_world = pose.R.transpose();
  const Vector3d C = pose.centre();
  std::ostringstream out;
  out.precision(17);
  out << "2759.48 0 1520.69 \n0 2764.16 1006.81 \n0 0 1 \n0 0 0\n";
  for (int r = 0; r < 3; ++r) {
    out << cam_to_world(r, 0) << ' ' << cam_to_world(r, 1) << ' '
        << cam_to_world(r, 2) << " \n";
  }
  out << C.x() << ' ' << C.y() << ' ' << C.z() << " \n3072 2048\n";
  return out.str();
}

// The real data folder `sub`, or empty when it is not there.
std::string shared_data(const std::string& sub) {
  const char* env = std::getenv("ARSCOUT_SHARED_DATA");
  const fs::path path = fs::path(env ? env : ARSCOUT_EVAL_SHARED_DATA) / sub;
  return fs::exists(path) ? path.string() : std::string();
}

// The numbers of a whitespace-separated file, read independently of the
// library under test.
std::vector<double> numbers_in(const fs::path& file) {
  std::ifstream in(file);
  std::vector<double> v;
  for (double x; in >> x;) v.push_back(x);
  return v;
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "(no exception)";
}

// ---- fit_similarity ----

TEST(FitSimilarity, RecoversAKnownSimilarityExactly) {
  std::mt19937 rng(7);
  const ev::Similarity truth{2.5, random_rotation(rng), Vector3d(3, -4, 12)};
  std::vector<Vector3d> from, to;
  for (int i = 0; i < 10; ++i) {
    from.push_back(random_vector(rng, 10));
    to.push_back(truth.apply(from.back()));
  }
  const ev::Similarity fit = ev::fit_similarity(from, to);
  EXPECT_NEAR(fit.scale, 2.5, 1e-12);
  EXPECT_LT((fit.R - truth.R).norm(), 1e-12);
  EXPECT_LT((fit.t - truth.t).norm(), 1e-10);
  EXPECT_NEAR(fit.R.determinant(), 1, 1e-12);
}

// A few points placed apart (a small component placed by its own fixes)
// pull the plain fit off; the robust fit is aligned by the others and says
// how many it used.
TEST(FitSimilarity, TheRobustFitIsNotPulledByAPartPlacedApart) {
  std::mt19937 rng(11);
  const ev::Similarity truth{0.5, random_rotation(rng), Vector3d(1, 2, 3)};
  std::normal_distribution<double> noise(0, 0.005);
  std::vector<Vector3d> from, to;
  for (int i = 0; i < 40; ++i) {
    from.push_back(random_vector(rng, 50));
    Vector3d jitter(noise(rng), noise(rng), noise(rng));
    to.push_back(truth.apply(from.back()) + jitter);
    if (i < 3) to.back() += Vector3d(1.8, 0, 0);
  }
  int used = 0;
  const ev::Similarity robust = ev::fit_similarity_robust(from, to, &used);
  const ev::Similarity plain = ev::fit_similarity(from, to);
  EXPECT_EQ(used, 37);
  double robust_error = 0, plain_error = 0;
  for (int i = 3; i < 40; ++i) {
    robust_error = std::max(
        robust_error, (robust.apply(from[i]) - truth.apply(from[i])).norm());
    plain_error = std::max(
        plain_error, (plain.apply(from[i]) - truth.apply(from[i])).norm());
  }
  EXPECT_LT(robust_error, 0.01);
  EXPECT_GT(plain_error, 0.1);
  // Without a part apart it is the plain fit.
  from.erase(from.begin(), from.begin() + 3);
  to.erase(to.begin(), to.begin() + 3);
  used = 0;
  const ev::Similarity clean = ev::fit_similarity_robust(from, to, &used);
  const ev::Similarity all = ev::fit_similarity(from, to);
  EXPECT_GE(used, 36);
  EXPECT_LT((clean.t - all.t).norm(), 0.01);
}

TEST(FitSimilarity, RejectsTooFewMismatchedOrCoincidentPoints) {
  const std::vector<Vector3d> two{Vector3d(0, 0, 0), Vector3d(1, 0, 0)};
  EXPECT_THROW(ev::fit_similarity(two, two), std::invalid_argument);
  const std::vector<Vector3d> three{Vector3d(0, 0, 0), Vector3d(1, 0, 0),
                                    Vector3d(0, 1, 0)};
  EXPECT_THROW(ev::fit_similarity(three, two), std::invalid_argument);
  const std::vector<Vector3d> same(3, Vector3d(1, 2, 3));
  EXPECT_THROW(ev::fit_similarity(same, three), std::invalid_argument);
}

// Moving the world and the camera together must not change what the camera
// sees: a point's camera coordinates only scale with the similarity.
TEST(TransformPose, KeepsWhatTheCameraSees) {
  std::mt19937 rng(8);
  const ev::Similarity sim{1.7, random_rotation(rng), random_vector(rng, 3)};
  const Pose pose =
      Pose::from_centre("a", random_rotation(rng), random_vector(rng, 4));
  const Pose moved = ev::transform_pose(sim, pose);
  EXPECT_LT((moved.centre() - sim.apply(pose.centre())).norm(), 1e-12);
  for (int i = 0; i < 5; ++i) {
    const Vector3d X = random_vector(rng, 10);
    const Vector3d seen = pose.R * X + pose.t;
    const Vector3d seen_after = moved.R * sim.apply(X) + moved.t;
    EXPECT_LT((seen_after - sim.scale * seen).norm(), 1e-10);
  }
}

// ---- compare_to_ground_truth ----

TEST(CompareToGroundTruth, SimilarityTransformedCopyHasNoError) {
  std::mt19937 rng(11);
  const auto truth = ring_of_cameras(12, 8.0, rng);
  const ev::Similarity sim = random_similarity(rng);
  const auto c = ev::compare_to_ground_truth(transformed(truth, sim), truth);
  EXPECT_EQ(c.matched, 12);
  EXPECT_EQ(c.truth_count, 12);
  EXPECT_LT(c.max_centre_error, 1e-9);
  EXPECT_LT(c.max_rotation_error_deg, 1e-6);
  EXPECT_LT(c.median_relative_rotation_error_deg, 1e-6);
  EXPECT_NEAR(c.scene_scale, 8.0, 1e-9);  // the ring radius
  const ev::Similarity undo = inverse(sim);
  EXPECT_NEAR(c.alignment.scale, undo.scale, 1e-9);
  EXPECT_LT((c.alignment.R - undo.R).norm(), 1e-9);
  EXPECT_LT((c.alignment.t - undo.t).norm(), 1e-9);
  ASSERT_EQ(c.cameras.size(), 12u);
}

TEST(CompareToGroundTruth, MatchesByNameAndIgnoresTheRest) {
  std::mt19937 rng(12);
  const auto truth = ring_of_cameras(8, 3.0, rng);
  auto estimated = transformed(truth, random_similarity(rng));
  estimated.erase("0003.jpg");
  estimated["extra.jpg"] =
      Pose::from_centre("extra.jpg", Matrix3d::Identity(), Vector3d(100, 0, 0));
  const auto c = ev::compare_to_ground_truth(estimated, truth);
  EXPECT_EQ(c.matched, 7);
  EXPECT_EQ(c.truth_count, 8);
  EXPECT_LT(c.max_centre_error, 1e-9);
}

// The true centres of four cameras at 0, 90, 180 and 270 degrees moved up,
// down, up, down by d: that leaves the cross-covariance and the centroids of
// the two point sets as they were, so the least-squares alignment is exact
// and each of the four is off by exactly d.
TEST(CompareToGroundTruth, DisplacementsTheFitCannotAbsorbAreMeasuredExactly) {
  std::mt19937 rng(13);
  const auto exact = ring_of_cameras(16, 10.0, rng);
  auto truth = exact;
  const double d = 0.5;
  const std::set<std::string> moved{"0000.jpg", "0004.jpg", "0008.jpg",
                                    "0012.jpg"};
  int k = 0;
  for (const auto& name : moved) {
    Pose& p = truth[name];
    p = Pose::from_centre(p.name, p.R,
                          p.centre() + Vector3d(0, 0, k++ % 2 ? -d : d));
  }
  const auto c = ev::compare_to_ground_truth(
      transformed(exact, random_similarity(rng)), truth);
  EXPECT_NEAR(c.max_centre_error, d, 1e-9);
  EXPECT_LT(c.median_centre_error, 1e-9);  // 12 of 16 untouched
  EXPECT_LT(c.max_rotation_error_deg, 1e-6);
  for (const auto& e : c.cameras) {
    EXPECT_NEAR(e.centre_error, moved.count(e.name) ? d : 0, 1e-9) << e.name;
    // The split into the true camera's depth axis and its image plane.
    const double along =
        moved.count(e.name) ? std::abs(truth.at(e.name).R(2, 2)) * d : 0;
    EXPECT_NEAR(e.along_axis_error, along, 1e-9) << e.name;
    EXPECT_NEAR(std::hypot(e.along_axis_error, e.across_axis_error),
                e.centre_error, 1e-9)
        << e.name;
  }
}

// One displaced camera: the fit absorbs a little of it (its leverage is
// about 7 / (3 n)), so it keeps most of the error and is the worst.
TEST(CompareToGroundTruth, OneDisplacedCameraStandsOut) {
  std::mt19937 rng(14);
  const auto truth = ring_of_cameras(40, 10.0, rng);
  auto moved = truth;
  Pose& p = moved["0005.jpg"];
  p = Pose::from_centre(p.name, p.R, p.centre() + Vector3d(0.3, -0.4, 0.0));
  const auto c = ev::compare_to_ground_truth(
      transformed(moved, random_similarity(rng)), truth);
  const auto worst = std::max_element(c.cameras.begin(), c.cameras.end(),
                                      [](const auto& a, const auto& b) {
                                        return a.centre_error < b.centre_error;
                                      });
  EXPECT_EQ(worst->name, "0005.jpg");
  EXPECT_GT(c.max_centre_error, 0.5 * 0.85);
  EXPECT_LT(c.max_centre_error, 0.5);
  EXPECT_LT(c.median_centre_error, 0.05);
}

// A camera turned on the spot leaves the centres, and so the fit, alone.
TEST(CompareToGroundTruth, RotatedCameraHasThatRotationError) {
  std::mt19937 rng(15);
  const auto truth = ring_of_cameras(10, 5.0, rng);
  auto turned = truth;
  Pose& p = turned["0002.jpg"];
  p = Pose::from_centre(p.name, rotation_about(Vector3d(1, 2, 3), 5.0) * p.R,
                        p.centre());
  const auto c = ev::compare_to_ground_truth(
      transformed(turned, random_similarity(rng)), truth);
  EXPECT_NEAR(c.max_rotation_error_deg, 5.0, 1e-9);
  EXPECT_LT(c.median_rotation_error_deg, 1e-6);
  EXPECT_LT(c.max_centre_error, 1e-9);
}

// A straight walk: the centres leave the fit's rotation about the walk's
// line to their noise, so every aligned camera carries the same tilt, which
// the relative figure takes out.
TEST(CompareToGroundTruth, AStraightWalkShowsTheFitsLooseTiltInEveryCamera) {
  std::mt19937 rng(17);
  std::normal_distribution<double> noise(0, 0.02);
  std::map<std::string, Pose> truth, estimated;
  const Matrix3d tilt = rotation_about(Vector3d::UnitX(), 4.0);
  const Matrix3d looking = rotation_about(Vector3d::UnitY(), 90.0);
  for (int i = 0; i < 40; ++i) {
    char name[16];
    std::snprintf(name, sizeof name, "%04d.jpg", i);
    const Vector3d centre(2.5 * i, 0.001 * std::sin(i), 1.6);
    truth[name] = Pose::from_centre(name, looking, centre);
    const double dy = noise(rng), dz = noise(rng);
    estimated[name] = Pose::from_centre(name, looking * tilt.transpose(),
                                        tilt * centre + Vector3d(0, dy, dz));
  }
  const auto c = ev::compare_to_ground_truth(estimated, truth);
  EXPECT_LT(c.median_centre_error, 0.05);
  EXPECT_GT(c.median_rotation_error_deg, 1.0);
  EXPECT_LT(c.median_relative_rotation_error_deg, 1e-6);
}

TEST(CompareToGroundTruth, NeedsThreeCommonNames) {
  std::mt19937 rng(16);
  const auto truth = ring_of_cameras(5, 1.0, rng);
  std::map<std::string, Pose> two{*truth.begin(), *std::next(truth.begin())};
  EXPECT_THROW(ev::compare_to_ground_truth(two, truth), std::invalid_argument);
}

TEST(RotationAngle, SmallAnglesKeepTheirPrecision) {
  const Matrix3d a = rotation_about(Vector3d(0, 1, 1), 1e-6);
  EXPECT_NEAR(ev::rotation_angle_deg(a, Matrix3d::Identity()), 1e-6, 1e-12);
  EXPECT_NEAR(ev::rotation_angle_deg(rotation_about(Vector3d::UnitX(), 179.0),
                                     Matrix3d::Identity()),
              179.0, 1e-9);
}

TEST(Median, OddEvenAndEmpty) {
  EXPECT_EQ(ev::median({3, 1, 2}), 2);
  EXPECT_EQ(ev::median({4, 1, 3, 2}), 2.5);
  EXPECT_TRUE(std::isnan(ev::median({})));
}

// ---- COLMAP text readers ----

using ColmapText = TempDirTest;

TEST_F(ColmapText, ImagesRoundTrip) {
  std::mt19937 rng(21);
  const auto poses =
      transformed(ring_of_cameras(5, 2.0, rng), random_similarity(rng));
  const auto read =
      ev::read_colmap_images_txt(write("images.txt", images_txt(poses)));
  ASSERT_EQ(read.size(), poses.size());
  for (const auto& [name, pose] : poses) {
    ASSERT_TRUE(read.count(name)) << name;
    EXPECT_LT((read.at(name).R - pose.R).norm(), 1e-12) << name;
    EXPECT_LT((read.at(name).t - pose.t).norm(), 1e-12) << name;
    EXPECT_EQ(read.at(name).camera_id, 1);
  }
}

TEST_F(ColmapText, ImageNamesMayContainSpaces) {
  const auto read = ev::read_colmap_images_txt(
      write("images.txt", "1 1 0 0 0 1 2 3 4 IMG 0001.jpg\n\n"));
  ASSERT_EQ(read.count("IMG 0001.jpg"), 1u);
  EXPECT_EQ(read.at("IMG 0001.jpg").centre(), Vector3d(-1, -2, -3));
  EXPECT_EQ(read.at("IMG 0001.jpg").camera_id, 4);
}

TEST_F(ColmapText, MalformedImagesNameFileAndLine) {
  const std::string header = "# comment\n";
  auto path = write("a/images.txt", header + "1 1 0 0 0 1 2 x 1 a.jpg\n\n");
  EXPECT_NE(error_of([&] {
              ev::read_colmap_images_txt(path);
            }).find("a/images.txt:2: bad number 'x'"),
            std::string::npos);
  path = write("b/images.txt", header + "1 1 0 0 0 1 2 3 1 a.jpg\n1 2\n");
  EXPECT_NE(error_of([&] {
              ev::read_colmap_images_txt(path);
            }).find("b/images.txt:3:"),
            std::string::npos);
  path = write("c/images.txt",
               "1 1 0 0 0 0 0 0 1 a.jpg\n\n"
               "2 1 0 0 0 0 0 0 1 a.jpg\n\n");
  EXPECT_NE(error_of([&] {
              ev::read_colmap_images_txt(path);
            }).find("c/images.txt:3: duplicate image name 'a.jpg'"),
            std::string::npos);
  path = write("d/images.txt", "1 2 0 0 0 0 0 0 1 a.jpg\n\n");
  EXPECT_THROW(ev::read_colmap_images_txt(path), std::runtime_error);
  path = write("e/images.txt", "1 1 0 0 0 0 0 0 a.jpg\n\n");
  EXPECT_THROW(ev::read_colmap_images_txt(path), std::runtime_error);
  EXPECT_THROW(ev::read_colmap_images_txt((dir_ / "missing.txt").string()),
               std::runtime_error);
}

TEST_F(ColmapText, Cameras) {
  const auto cams = ev::read_colmap_cameras_txt(
      write("cameras.txt",
            "# Camera list with one line of data per camera:\n"
            "1 PINHOLE 3072 2048 2759.48 2764.16 1520.69 1006.81\n"
            "2 SIMPLE_RADIAL 640 480 1520.4 302.32 246.87 -0.01\n"));
  ASSERT_EQ(cams.size(), 2u);
  EXPECT_EQ(cams.at(1).model, "PINHOLE");
  EXPECT_EQ(cams.at(1).width, 3072);
  EXPECT_EQ(cams.at(1).height, 2048);
  EXPECT_EQ(cams.at(1).params,
            (std::vector<double>{2759.48, 2764.16, 1520.69, 1006.81}));
  EXPECT_EQ(cams.at(2).params.back(), -0.01);
  const auto bad = write("bad.txt", "1 PINHOLE 3072\n");
  EXPECT_NE(
      error_of([&] { ev::read_colmap_cameras_txt(bad); }).find("bad.txt:1:"),
      std::string::npos);
}

TEST_F(ColmapText, Points3D) {
  const auto points = ev::read_colmap_points3d_txt(
      write("points3D.txt",
            "# 3D point list with one line of data per point:\n"
            "7 1.5 -2 3e1 255 128 0 0.75 1 10 2 20 5 0\n"
            "8 0 0 0 1 2 3 0.1\n"));
  ASSERT_EQ(points.size(), 2u);
  EXPECT_EQ(points[0].id, 7u);
  EXPECT_EQ(points[0].xyz, Vector3d(1.5, -2, 30));
  EXPECT_EQ(points[0].rgb, Eigen::Vector3i(255, 128, 0));
  EXPECT_EQ(points[0].error, 0.75);
  EXPECT_EQ(points[0].track_length, 3);
  EXPECT_EQ(points[1].track_length, 0);
  const auto odd = write("odd.txt", "7 1 2 3 4 5 6 0.5 1\n");
  EXPECT_THROW(ev::read_colmap_points3d_txt(odd), std::runtime_error);
  const auto colour = write("colour.txt", "7 1 2 3 4 5 256 0.5\n");
  EXPECT_THROW(ev::read_colmap_points3d_txt(colour), std::runtime_error);
}

TEST_F(ColmapText, TracksGroupKeypointsByPointId) {
  const auto tracks = ev::read_colmap_tracks(
      write("images.txt",
            "# comment\n"
            "1 1 0 0 0 0 0 0 1 a.jpg\n10.5 20.25 7 30 40 -1\n"
            "2 1 0 0 0 0 0 0 1 b.jpg\n1 2 7 3 4 8\n"
            "3 1 0 0 0 0 0 0 1 c.jpg\n"));
  ASSERT_EQ(tracks.size(), 2u);
  ASSERT_EQ(tracks.at(7).size(), 2u);
  EXPECT_EQ(tracks.at(7)[0].image, "a.jpg");
  EXPECT_EQ(tracks.at(7)[0].xy, Vector2d(10.5, 20.25));
  EXPECT_EQ(tracks.at(7)[1].image, "b.jpg");
  EXPECT_EQ(tracks.at(7)[1].xy, Vector2d(1, 2));
  ASSERT_EQ(tracks.at(8).size(), 1u);
  EXPECT_EQ(tracks.at(8)[0].xy, Vector2d(3, 4));
  const auto bad = write("bad.txt", "1 1 0 0 0 0 0 0 1 a.jpg\n1 2 x\n");
  EXPECT_NE(error_of([&] { ev::read_colmap_tracks(bad); }).find("bad.txt:2:"),
            std::string::npos);
}

// ---- Observation fit ----

// OpenCV's distortion (k1 k2 p1 p2) of a normalised point, written out
// independently of the library.
Vector2d distort(const std::array<double, 4>& d, const Vector2d& x) {
  const double r2 = x.squaredNorm();
  const double radial = 1 + d[0] * r2 + d[1] * r2 * r2;
  return {x.x() * radial + 2 * d[2] * x.x() * x.y() +
              d[3] * (r2 + 2 * x.x() * x.x()),
          x.y() * radial + d[2] * (r2 + 2 * x.y() * x.y()) +
              2 * d[3] * x.x() * x.y()};
}

// A ring of 8 cameras round 200 points in a 3 m cube at the origin, every
// point in front of every camera; written as a COLMAP text model whose
// keypoints are the points' projections, one camera per image.
class FitObservations : public TempDirTest {
 protected:
  static constexpr double kFocal = 1000;
  static constexpr double kCx = 640.5, kCy = 480.5;  // COLMAP's convention

  void SetUp() override {
    TempDirTest::SetUp();
    poses_ = ring_of_cameras(8, 10.0, rng_);
    std::uniform_real_distribution<double> coordinate(-1.5, 1.5);
    for (int i = 0; i < 200; ++i) {
      const double x = coordinate(rng_), y = coordinate(rng_),
                   z = coordinate(rng_);
      points_.emplace_back(x, y, z);
    }
  }

  // Every point seen by every camera, keypoints off by Gaussian noise of
  // `noise_px` per axis; OPENCV cameras when there is distortion.
  void write_model(double noise_px, const std::array<double, 4>& d = {}) {
    const bool opencv = d != std::array<double, 4>{};
    std::ostringstream cameras, images;
    cameras.precision(17);
    images.precision(17);
    std::normal_distribution<double> noise(0, noise_px);
    int id = 1;
    for (const auto& [name, pose] : poses_) {
      cameras << id << (opencv ? " OPENCV" : " PINHOLE") << " 1280 960 "
              << kFocal << ' ' << kFocal << ' ' << kCx << ' ' << kCy;
      if (opencv)
        cameras << ' ' << d[0] << ' ' << d[1] << ' ' << d[2] << ' ' << d[3];
      cameras << "\n";
      const Eigen::Quaterniond q(pose.R);
      images << id << ' ' << q.w() << ' ' << q.x() << ' ' << q.y() << ' '
             << q.z() << ' ' << pose.t.x() << ' ' << pose.t.y() << ' '
             << pose.t.z() << ' ' << id << ' ' << name << "\n";
      images << "5 5 -1";  // a keypoint of no point, to be ignored
      for (std::size_t j = 0; j < points_.size(); ++j) {
        const Vector3d c = pose.R * points_[j] + pose.t;
        const Vector2d x = distort(d, c.head<2>() / c.z());
        images << ' ' << kFocal * x.x() + kCx + noise(rng_) << ' '
               << kFocal * x.y() + kCy + noise(rng_) << ' ' << j;
      }
      images << "\n";
      ++id;
    }
    write("sparse/cameras.txt", cameras.str());
    write("sparse/images.txt", images.str());
  }

  // The written model's keypoints judged with `poses`.
  ev::ObservationFit fit(const std::map<std::string, Pose>& poses) const {
    const auto model = dir_ / "sparse";
    std::map<std::string, int> camera_ids;
    for (const auto& [name, pose] :
         ev::read_colmap_images_txt((model / "images.txt").string())) {
      camera_ids[name] = pose.camera_id;
    }
    return ev::fit_observations(
        poses, ev::read_colmap_cameras_txt((model / "cameras.txt").string()),
        camera_ids, ev::read_colmap_tracks((model / "images.txt").string()));
  }

  std::mt19937 rng_{51};
  std::map<std::string, Pose> poses_;
  std::vector<Vector3d> points_;
};

TEST_F(FitObservations, TruePosesExplainExactKeypointsExactly) {
  write_model(0);
  const auto f = fit(poses_);
  EXPECT_EQ(f.points, 200);
  EXPECT_EQ(f.observations, 200 * 8);
  EXPECT_EQ(f.skipped_points, 0);
  EXPECT_LT(f.median_px, 1e-6);
  EXPECT_LT(f.p90_px, 1e-6);
  EXPECT_LT(f.mean_clipped_px, 1e-6);
  ASSERT_EQ(f.image_median_px.size(), 8u);
  for (const auto& [name, m] : f.image_median_px) EXPECT_LT(m, 1e-6) << name;
}

// The poses may be in any frame: the points are re-triangulated in theirs.
TEST_F(FitObservations, PosesInAnotherFrameFitAsWell) {
  write_model(0);
  EXPECT_LT(fit(transformed(poses_, random_similarity(rng_))).median_px, 1e-6);
}

TEST_F(FitObservations, ImagesWithoutAPoseDropOut) {
  write_model(0);
  auto poses = poses_;
  poses.erase("0005.jpg");
  const auto f = fit(poses);
  EXPECT_EQ(f.observations, 200 * 7);
  EXPECT_EQ(f.image_median_px.count("0005.jpg"), 0u);
  // With one image left no point can be triangulated.
  const std::map<std::string, Pose> one{*poses_.begin()};
  EXPECT_EQ(fit(one).observations, 0);
  EXPECT_TRUE(std::isnan(fit(one).median_px));
}

TEST_F(FitObservations, UndistortsOpenCvKeypoints) {
  write_model(0, {-0.12, 0.03, 1e-3, -5e-4});
  EXPECT_LT(fit(poses_).median_px, 1e-6);
  EXPECT_LT(fit(poses_).p90_px, 1e-6);
}

// The residual of a point seen n times is the noise less its projection
// onto the point's 3 degrees of freedom: per axis sigma * sqrt(1 - 3/(2n)),
// 0.45 px for n = 8. Its length has a Rayleigh distribution, median
// 1.177 and 90th percentile 2.146 times that: 0.53 px and 0.97 px.
TEST_F(FitObservations, NoisyKeypointsGiveTheExpectedResidual) {
  write_model(0.5);
  const auto f = fit(poses_);
  EXPECT_EQ(f.observations, 200 * 8);
  EXPECT_GT(f.median_px, 0.45);
  EXPECT_LT(f.median_px, 0.6);
  EXPECT_GT(f.p90_px, 0.85);
  EXPECT_LT(f.p90_px, 1.1);
  EXPECT_GT(f.mean_clipped_px, 0.45);
  EXPECT_LT(f.mean_clipped_px, 0.65);
}

// Half a degree is 8.7 px at this focal length; the re-triangulated points
// follow the seven good cameras, so the turned one keeps most of it (6.9 px
// against at most 1.9 px in the others).
TEST_F(FitObservations, ATurnedCameraStandsOut) {
  write_model(0);
  auto poses = poses_;
  Pose& p = poses["0003.jpg"];
  p = Pose::from_centre(p.name, rotation_about(Vector3d(1, 2, 0), 0.5) * p.R,
                        p.centre());
  const auto f = fit(poses);
  double others = 0;
  for (const auto& [name, m] : f.image_median_px) {
    if (name != "0003.jpg") others = std::max(others, m);
  }
  EXPECT_GT(f.image_median_px.at("0003.jpg"), 5.0);
  EXPECT_GT(f.image_median_px.at("0003.jpg"), 2.5 * others);
}

// A point just outside the ring behind camera 0 projects through it (a
// pinhole cannot tell) and is in front of the other seven: it triangulates
// exactly, behind camera 0, and is skipped.
TEST_F(FitObservations, APointBehindACameraIsSkipped) {
  ASSERT_EQ(poses_.begin()->second.centre().x(), 10.0);  // camera 0
  points_.emplace_back(12, 0.5, 0.3);
  write_model(0);
  const auto f = fit(poses_);
  EXPECT_EQ(f.skipped_points, 1);
  EXPECT_EQ(f.points, 200);
  EXPECT_EQ(f.observations, 200 * 8);
  EXPECT_LT(f.median_px, 1e-6);
}

TEST_F(FitObservations, UnsupportedOrMissingCamerasAreErrors) {
  write_model(0);
  const auto tracks =
      ev::read_colmap_tracks((dir_ / "sparse/images.txt").string());
  std::map<std::string, int> ids;
  for (const auto& [name, pose] : poses_) ids[name] = 1;
  const std::map<int, ev::ColmapCamera> fisheye{
      {1,
       {1, "OPENCV_FISHEYE", 1280, 960, {1000, 1000, 640, 480, 0, 0, 0, 0}}}};
  EXPECT_THROW(ev::fit_observations(poses_, fisheye, ids, tracks),
               std::invalid_argument);
  const std::map<int, ev::ColmapCamera> short_params{
      {1, {1, "PINHOLE", 1280, 960, {1000, 1000, 640}}}};
  EXPECT_THROW(ev::fit_observations(poses_, short_params, ids, tracks),
               std::invalid_argument);
  const std::map<int, ev::ColmapCamera> other_id{
      {2, {2, "PINHOLE", 1280, 960, {1000, 1000, 640, 480}}}};
  EXPECT_THROW(ev::fit_observations(poses_, other_id, ids, tracks),
               std::invalid_argument);
  EXPECT_THROW(ev::fit_observations(poses_, other_id, {}, tracks),
               std::invalid_argument);
}

// ---- Ground-truth readers ----

using GroundTruth = TempDirTest;

TEST_F(GroundTruth, StrechaFileInTheDocumentedFormat) {
  std::mt19937 rng(31);
  const auto poses = ring_of_cameras(3, 9.0, rng);
  for (const auto& [name, pose] : poses) {
    write("gt/" + name + ".camera", strecha_camera(pose));
  }
  write("gt/README", "not a camera");
  const auto read = ev::read_strecha_ground_truth((dir_ / "gt").string());
  ASSERT_EQ(read.size(), 3u);
  for (const auto& [name, pose] : poses) {
    ASSERT_TRUE(read.count(name)) << name;
    EXPECT_LT((read.at(name).R - pose.R).norm(), 1e-12);
    EXPECT_LT((read.at(name).centre() - pose.centre()).norm(), 1e-12);
  }
}

// The file's R has the camera axes as columns: the optical axis (third
// column) must point from C towards a point in front of the camera.
TEST_F(GroundTruth, StrechaRotationIsCameraToWorld) {
  write("gt/a.jpg.camera",
        "1 0 0\n0 1 0\n0 0 1\n0 0 0\n"
        "0 1 0\n0 0 1\n1 0 0\n"  // camera z = world y
        "1 2 3\n640 480\n");
  const Pose p =
      ev::read_strecha_ground_truth((dir_ / "gt").string()).at("a.jpg");
  EXPECT_LT((p.centre() - Vector3d(1, 2, 3)).norm(), 1e-12);
  const Vector3d in_front = p.R * Vector3d(1, 7, 3) + p.t;
  EXPECT_LT((in_front - Vector3d(0, 0, 5)).norm(), 1e-12);
}

TEST_F(GroundTruth, StrechaMalformed) {
  write("short/a.jpg.camera", "1 0 0\n0 1 0\n0 0 1\n");
  EXPECT_NE(error_of([&] {
              ev::read_strecha_ground_truth((dir_ / "short").string());
            }).find("a.jpg.camera:3: expected 26 numbers"),
            std::string::npos);
  write("skew/a.jpg.camera",
        "1 0 0\n0 1 0\n0 0 1\n0 0 0\n1 1 0\n0 1 0\n0 0 1\n0 0 0\n1 1\n");
  EXPECT_THROW(ev::read_strecha_ground_truth((dir_ / "skew").string()),
               std::runtime_error);
  fs::create_directories(dir_ / "empty");
  EXPECT_THROW(ev::read_strecha_ground_truth((dir_ / "empty").string()),
               std::runtime_error);
  EXPECT_THROW(ev::read_strecha_ground_truth((dir_ / "none").string()),
               std::runtime_error);
}

TEST_F(GroundTruth, MiddleburyPar) {
  std::mt19937 rng(32);
  const auto poses = ring_of_cameras(2, 0.6, rng);
  std::ostringstream text;
  text.precision(17);
  text << poses.size() << "\n";
  for (const auto& [name, p] : poses) {
    text << name << " 1520.4 0 302.32 0 1525.9 246.87 0 0 1";
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) text << ' ' << p.R(r, c);
    }
    text << ' ' << p.t.x() << ' ' << p.t.y() << ' ' << p.t.z() << "\n";
  }
  const auto read = ev::read_middlebury_par(write("par.txt", text.str()));
  ASSERT_EQ(read.size(), 2u);
  for (const auto& [name, p] : poses) {
    EXPECT_LT((read.at(name).R - p.R).norm(), 1e-12);
    EXPECT_LT((read.at(name).t - p.t).norm(), 1e-12);
  }
  const auto wrong_count = write("three.txt", "3\n" + text.str().substr(2));
  EXPECT_THROW(ev::read_middlebury_par(wrong_count), std::runtime_error);
}

// ---- Geo CSV ----

using GeoCsv = TempDirTest;

TEST_F(GeoCsv, OursAndStrechaLayouts) {
  const auto ours = ev::read_geo_csv(
      write("cameras_geo.csv",
            "image,latitude,longitude,altitude\n"
            "0000.jpg,46.5191,6.5668,400.5\n0001.jpg,46.5192,6.5669,401\n"));
  ASSERT_EQ(ours.size(), 2u);
  EXPECT_EQ(ours.at("0001.jpg").lat, 46.5192);
  EXPECT_EQ(ours.at("0001.jpg").alt, 401);
  const auto theirs = ev::read_geo_csv(
      write("gps.csv",
            "altitude, Longitude ,image,latitude,horizontal_accuracy_m\r\n"
            "399.5,6.5667,0000.jpg,46.519,2.12\r\n"));
  EXPECT_EQ(theirs.at("0000.jpg").lon, 6.5667);
  EXPECT_EQ(theirs.at("0000.jpg").alt, 399.5);
}

TEST_F(GeoCsv, Malformed) {
  EXPECT_NE(error_of([&] {
              ev::read_geo_csv(write("a.csv", "image,latitude,longitude\n"));
            }).find("a.csv:1: header has no 'altitude' column"),
            std::string::npos);
  EXPECT_THROW(ev::read_geo_csv(write("b.csv",
                                      "image,latitude,longitude,altitude\n"
                                      "x.jpg,46.5,6.5\n")),
               std::runtime_error);
  EXPECT_THROW(ev::read_geo_csv(write("c.csv",
                                      "image,latitude,longitude,altitude\n"
                                      "x.jpg,146.5,6.5,3\n")),
               std::runtime_error);
  EXPECT_THROW(ev::read_geo_csv(write("d.csv", "")), std::runtime_error);
}

TEST(GeoDistance, KnownOffsets) {
  // One degree of latitude is about 111 km; use small offsets instead.
  const std::map<std::string, ev::GeoRow> truth{{"a", {46.5191, 6.5668, 400}},
                                                {"b", {46.5192, 6.5668, 400}},
                                                {"c", {46.5191, 6.5669, 400}}};
  auto shifted = truth;
  for (auto& [name, row] : shifted) row.alt += 2.0;
  shifted["only_here"] = {0, 0, 0};
  int matched = 0;
  EXPECT_NEAR(ev::median_geo_distance(shifted, truth, &matched), 2.0, 1e-6);
  EXPECT_EQ(matched, 3);
  EXPECT_EQ(ev::median_geo_distance(truth, truth, nullptr), 0.0);
  const std::map<std::string, ev::GeoRow> other{{"z", {46, 6, 0}}};
  EXPECT_THROW(ev::median_geo_distance(other, truth, &matched),
               std::invalid_argument);
}

// Small horizontal offsets against the WGS84 radii of curvature: north is
// M * dlat, east N * cos(lat) * dlon.
TEST(GeoDistance, HorizontalOffsetsInMetres) {
  const double a = 6378137, f = 1 / 298.257223563, e2 = f * (2 - f);
  const double lat = 46.5191, rad = std::numbers::pi / 180;
  const double w = 1 - e2 * std::pow(std::sin(lat * rad), 2);
  const double M = a * (1 - e2) / std::pow(w, 1.5), N = a / std::sqrt(w);
  const std::map<std::string, ev::GeoRow> here{{"a", {lat, 6.5668, 400}}};
  const std::map<std::string, ev::GeoRow> north{
      {"a", {lat + 1e-4, 6.5668, 400}}};
  const std::map<std::string, ev::GeoRow> east{{"a", {lat, 6.5669, 400}}};
  EXPECT_NEAR(ev::median_geo_distance(north, here, nullptr), M * 1e-4 * rad,
              2e-3);
  EXPECT_NEAR(ev::median_geo_distance(east, here, nullptr),
              N * std::cos(lat * rad) * 1e-4 * rad, 2e-3);
}

// ---- The real ground truth in ../shared/data ----

TEST(SharedData, FountainGroundTruthCentresAreTheCRows) {
  const std::string scene = shared_data("strecha/fountain-P11");
  if (scene.empty()) GTEST_SKIP() << "../shared/data/strecha not found";
  const fs::path gt = fs::path(scene) / "gt_dense_cameras";
  const auto poses = ev::read_strecha_ground_truth(gt.string());
  ASSERT_EQ(poses.size(), 11u);
  for (const auto& [name, pose] : poses) {
    const auto v = numbers_in(gt / (name + ".camera"));
    ASSERT_EQ(v.size(), 26u);
    EXPECT_LT((pose.centre() - Vector3d(v[21], v[22], v[23])).norm(), 1e-9)
        << name;
    // Optical axis = third column of the file's camera-to-world R.
    EXPECT_LT(
        (pose.R.row(2).transpose() - Vector3d(v[14], v[17], v[20])).norm(),
        1e-5)
        << name;
  }
  // The README: a walk 8-10 m in front of the wall.
  const auto self = ev::compare_to_ground_truth(poses, poses);
  EXPECT_EQ(self.matched, 11);
  EXPECT_LT(self.max_centre_error, 1e-9);
  EXPECT_GT(self.scene_scale, 1.0);
  EXPECT_LT(self.scene_scale, 20.0);
}

TEST(SharedData, MiddleburyTempleProjectsIntoEveryImage) {
  const std::string scene = shared_data("middlebury/templeSparseRing");
  if (scene.empty()) GTEST_SKIP() << "../shared/data/middlebury not found";
  const auto poses =
      ev::read_middlebury_par((fs::path(scene) / "templeSR_par.txt").string());
  ASSERT_EQ(poses.size(), 16u);
  // The bounding-box centre from the README is in front of every camera.
  const Vector3d object(-0.022357, 0.10181, 0.0251455);
  for (const auto& [name, pose] : poses) {
    EXPECT_GT((pose.R * object + pose.t).z(), 0.3) << name;
  }
}

TEST(SharedData, FountainGpsDistances) {
  const std::string scene = shared_data("strecha/fountain-P11");
  if (scene.empty()) GTEST_SKIP() << "../shared/data/strecha not found";
  const auto truth = ev::read_geo_csv(scene + "/gps_truth.csv");
  const auto noisy = ev::read_geo_csv(scene + "/gps.csv");
  int matched = 0;
  EXPECT_LT(ev::median_geo_distance(truth, truth, &matched), 1e-9);
  EXPECT_EQ(matched, 11);
  const double d = ev::median_geo_distance(noisy, truth, &matched);
  EXPECT_EQ(matched, 11);
  // Noise of 1.5 m per horizontal axis and 3 m vertically.
  EXPECT_GT(d, 1.0);
  EXPECT_LT(d, 5.0);
}

// The path the reconstruction tests take: ground truth written as a COLMAP
// model, read back and compared, is its own perfect estimate.
using RoundTrip = TempDirTest;

TEST_F(RoundTrip, FountainGroundTruthAsColmapModelComparesToItself) {
  const std::string scene = shared_data("strecha/fountain-P11");
  if (scene.empty()) GTEST_SKIP() << "../shared/data/strecha not found";
  const auto truth = ev::read_strecha_ground_truth(scene + "/gt_dense_cameras");
  std::mt19937 rng(41);
  const auto model = ev::read_colmap_images_txt(write(
      "images.txt", images_txt(transformed(truth, random_similarity(rng)))));
  const auto c = ev::compare_to_ground_truth(model, truth);
  EXPECT_EQ(c.matched, 11);
  EXPECT_LT(c.max_centre_error, 1e-9);
  EXPECT_LT(c.max_rotation_error_deg, 1e-6);
}

}  // namespace
