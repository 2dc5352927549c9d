// Chessboard calibration against photos rendered here with exact ground
// truth: a pinhole camera with radial distortion looks at a planar board
// from known poses, so the recovered intrinsics can be compared with the
// camera that took the pictures.
#include "arscout/engine/calibration.h"

#include <sys/wait.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "arscout/db/store.h"
#include "arscout/ingest/auth.h"
#include "arscout/ingest/server.h"
#include "test_stores.h"
#include "tool_process.h"

namespace arscout::ingest {

using engine::BoardSize;
using engine::calibrate_chessboard;
using engine::CameraCalibration;
using engine::parse_board_size;
namespace {

namespace fs = std::filesystem;

// The camera that takes the pictures.
constexpr int kWidth = 1280;
constexpr int kHeight = 960;
constexpr double kFocal = 1000;
constexpr double kCx = 640;
constexpr double kCy = 480;
constexpr double kK1 = -0.1;

// A board of 10 x 7 squares (9 x 6 inner corners) with a white margin of one
// square, as printed targets have: findChessboardCorners needs it.
constexpr BoardSize kBoard{9, 6};
constexpr double kSquareM = 0.025;
// Squares = inner corners + 1, plus the margin on both sides.
constexpr int kSquaresX = kBoard.cols + 3;
constexpr int kSquaresY = kBoard.rows + 3;
constexpr int kTexelsPerSquare = 100;  // 0.25 mm, finer than any view's pixel
constexpr double kTexelsPerM = kTexelsPerSquare / kSquareM;

// Camera pose relative to the board: rotations in degrees applied x, then
// y, then z, and the board centre's position in the camera frame (metres).
struct Pose {
  double rx, ry, rz;
  double tx, ty, tz;
};

// Tilted views (which fix the focal length) and off-centre ones (whose
// corners reach where the distortion is strong).
constexpr Pose kPoses[] = {
    {0, 0, 0, 0, 0, 0.55},
    {25, 0, 0, 0, 0, 0.55},
    {-25, 0, 5, 0, 0, 0.55},
    {0, 30, 0, 0, 0, 0.55},
    {0, -30, -5, 0, 0, 0.55},
    {15, 20, 10, -0.15, -0.10, 0.6},
    {-15, 20, -10, 0.15, -0.10, 0.6},
    {15, -20, 8, -0.15, 0.10, 0.6},
    {-20, -15, -8, 0.15, 0.10, 0.6},
    {10, 10, 30, 0, 0, 0.5},
};

// The board as a texture, 20 (black) to 230 (white), its edges softened so
// that bilinear sampling does not alias.
cv::Mat board_texture() {
  cv::Mat tex(kSquaresY * kTexelsPerSquare, kSquaresX * kTexelsPerSquare,
              CV_32F);
  for (int v = 0; v < tex.rows; ++v) {
    for (int u = 0; u < tex.cols; ++u) {
      int a = u / kTexelsPerSquare, b = v / kTexelsPerSquare;
      bool margin =
          a == 0 || b == 0 || a == kSquaresX - 1 || b == kSquaresY - 1;
      tex.at<float>(v, u) = margin || (a + b) % 2 == 1 ? 230.0f : 20.0f;
    }
  }
  cv::GaussianBlur(tex, tex, cv::Size(), 1.5);
  return tex;
}

// For every pixel of the distorted image, the undistorted normalised ray
// (x, y, 1) that the camera maps there: x (1 + k1 r^2) = (u - cx) / f,
// solved by fixed-point iteration (it contracts for this mild k1).
cv::Mat ideal_rays() {
  cv::Mat rays(kHeight, kWidth, CV_64FC2);
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      double xd = (u - kCx) / kFocal, yd = (v - kCy) / kFocal;
      double x = xd, y = yd;
      for (int i = 0; i < 30; ++i) {
        double scale = 1 + kK1 * (x * x + y * y);
        x = xd / scale;
        y = yd / scale;
      }
      rays.at<cv::Vec2d>(v, u) = {x, y};
    }
  }
  return rays;
}

cv::Matx33d rotation(const Pose& p) {
  auto rad = [](double deg) { return deg * CV_PI / 180; };
  double a = rad(p.rx), b = rad(p.ry), c = rad(p.rz);
  cv::Matx33d rx(1, 0, 0, 0, std::cos(a), -std::sin(a), 0, std::sin(a),
                 std::cos(a));
  cv::Matx33d ry(std::cos(b), 0, std::sin(b), 0, 1, 0, -std::sin(b), 0,
                 std::cos(b));
  cv::Matx33d rz(std::cos(c), -std::sin(c), 0, std::sin(c), std::cos(c), 0, 0,
                 0, 1);
  return rz * ry * rx;
}

// Where each pixel's ray meets the board plane, in texel coordinates: the
// inverse of the plane-induced homography [r1 r2 t] applied to the ray.
void texel_map(const cv::Mat& rays, const Pose& pose, cv::Mat* map_x,
               cv::Mat* map_y) {
  cv::Matx33d r = rotation(pose);
  cv::Matx33d h(r(0, 0), r(0, 1), pose.tx, r(1, 0), r(1, 1), pose.ty, r(2, 0),
                r(2, 1), pose.tz);
  cv::Matx33d h_inv = h.inv();
  map_x->create(rays.size(), CV_32F);
  map_y->create(rays.size(), CV_32F);
  for (int v = 0; v < rays.rows; ++v) {
    for (int u = 0; u < rays.cols; ++u) {
      cv::Vec2d ray = rays.at<cv::Vec2d>(v, u);
      cv::Vec3d board = h_inv * cv::Vec3d(ray[0], ray[1], 1);
      bool in_front = board[2] > 0;  // the depth along the ray is 1/board[2]
      double x = board[0] / board[2], y = board[1] / board[2];
      map_x->at<float>(v, u) =
          in_front ? static_cast<float>(
                         (x + kSquaresX * kSquareM / 2) * kTexelsPerM - 0.5)
                   : -1e6f;
      map_y->at<float>(v, u) =
          in_front ? static_cast<float>(
                         (y + kSquaresY * kSquareM / 2) * kTexelsPerM - 0.5)
                   : -1e6f;
    }
  }
}

// One photo: the board on a grey background, slightly out of focus, with
// sensor noise.
cv::Mat render_view(const cv::Mat& texture, const cv::Mat& rays,
                    const Pose& pose, cv::RNG& rng) {
  cv::Mat map_x, map_y, image;
  texel_map(rays, pose, &map_x, &map_y);
  cv::remap(texture, image, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT,
            cv::Scalar(120));
  cv::GaussianBlur(image, image, cv::Size(), 0.7);
  cv::Mat noise(image.size(), CV_32F);
  rng.fill(noise, cv::RNG::NORMAL, 0, 2.0);
  image += noise;
  cv::Mat out;
  image.convertTo(out, CV_8U);
  return out;
}

// A photo of a wall without any board.
cv::Mat blank_view(cv::RNG& rng) {
  cv::Mat image(kHeight, kWidth, CV_8U);
  rng.fill(image, cv::RNG::NORMAL, 128, 6.0);
  cv::GaussianBlur(image, image, cv::Size(), 2.0);
  return image;
}

std::string write_png(const std::string& dir, const std::string& name,
                      const cv::Mat& image) {
  std::string path = dir + "/" + name;
  if (!cv::imwrite(path, image))
    throw std::runtime_error("cannot write " + path);
  return path;
}

// Exit code of `arscout ARGS`, its output in `log`.
int run_cli(const std::string& args, const std::string& log) {
  std::string command =
      std::string(ARSCOUT_CLI) + " " + args + " > '" + log + "' 2>&1";
  int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

class CalibrationTest : public ::testing::Test {
 protected:
  // Rendering takes a second or two, so all tests share one set of photos:
  // view-00.png ... view-09.png and blank.png in one folder.
  static void SetUpTestSuite() {
    dir_ = new std::string(arscout::testing::make_temp_dir("calibration"));
    views_ = new std::vector<std::string>;
    cv::Mat texture = board_texture();
    cv::Mat rays = ideal_rays();
    cv::RNG rng(20261121);
    for (const Pose& pose : kPoses) {
      std::string name = "view-0" + std::to_string(views_->size()) + ".png";
      views_->push_back(
          write_png(*dir_, name, render_view(texture, rays, pose, rng)));
    }
    // Files that must not reach the CLI test's folder listing.
    extra_ = new std::string(*dir_ + "/extra");
    fs::create_directories(*extra_);
    blank_ = new std::string(write_png(*dir_, "blank.png", blank_view(rng)));
  }
  static void TearDownTestSuite() {
    std::error_code ignored;
    fs::remove_all(*dir_, ignored);
    delete dir_;
    delete views_;
    delete blank_;
    delete extra_;
  }

  static std::string* dir_;
  static std::vector<std::string>* views_;
  static std::string* blank_;
  static std::string* extra_;  // a subfolder, which the CLI does not list
};

std::string* CalibrationTest::dir_ = nullptr;
std::vector<std::string>* CalibrationTest::views_ = nullptr;
std::string* CalibrationTest::blank_ = nullptr;
std::string* CalibrationTest::extra_ = nullptr;

TEST_F(CalibrationTest, RecoversTheRenderingCamera) {
  std::vector<std::string> paths = *views_;
  paths.insert(paths.begin() + 3, *blank_);
  std::vector<std::string> rejected;
  std::vector<std::string> reported;
  auto c = calibrate_chessboard(
      paths, kBoard, kSquareM, &rejected,
      [&](const std::string& path, const std::string& problem) {
        reported.push_back(fs::path(path).filename().string() + " " +
                           (problem.empty() ? "found" : "rejected"));
      });

  EXPECT_EQ(c.width, kWidth);
  EXPECT_EQ(c.height, kHeight);
  EXPECT_EQ(c.images_used, 10);
  EXPECT_NEAR(c.fx, kFocal, 0.005 * kFocal);
  EXPECT_NEAR(c.fy, kFocal, 0.005 * kFocal);
  EXPECT_NEAR(c.cx, kCx, 2.0);
  EXPECT_NEAR(c.cy, kCy, 2.0);
  EXPECT_NEAR(c.k1, kK1, 0.01);
  EXPECT_NEAR(c.k2, 0.0, 0.05);
  EXPECT_NEAR(c.p1, 0.0, 1e-3);
  EXPECT_NEAR(c.p2, 0.0, 1e-3);
  EXPECT_EQ(c.k3, 0.0);  // fixed
  EXPECT_LT(c.rms_px, 0.5);
  EXPECT_EQ(c.source, "calibrated");
  std::cout << "recovered fx " << c.fx << " fy " << c.fy << " cx " << c.cx
            << " cy " << c.cy << " k1 " << c.k1 << " k2 " << c.k2 << " p1 "
            << c.p1 << " p2 " << c.p2 << " rms " << c.rms_px << " px\n";

  ASSERT_EQ(rejected.size(), 1u);
  EXPECT_EQ(rejected[0].rfind(*blank_ + ": ", 0), 0u) << rejected[0];
  EXPECT_NE(rejected[0].find("not found"), std::string::npos) << rejected[0];
  ASSERT_EQ(reported.size(), paths.size());
  EXPECT_EQ(reported[0], "view-00.png found");
  EXPECT_EQ(reported[3], "blank.png rejected");
}

// Phone-sized photos are searched at a reduced size and refined at full
// size; the same views at twice the size must give twice the focal length.
TEST_F(CalibrationTest, LargePhotosAreCalibratedAtFullResolution) {
  std::vector<std::string> paths;
  for (std::size_t i = 0; i < 6; ++i) {
    cv::Mat large;
    cv::resize(cv::imread((*views_)[i], cv::IMREAD_GRAYSCALE), large,
               cv::Size(2 * kWidth, 2 * kHeight), 0, 0, cv::INTER_CUBIC);
    paths.push_back(
        write_png(*extra_, "large-" + std::to_string(i) + ".png", large));
  }
  auto c = calibrate_chessboard(paths, kBoard, kSquareM, nullptr);
  for (const auto& path : paths) fs::remove(path);
  EXPECT_EQ(c.width, 2 * kWidth);
  EXPECT_EQ(c.images_used, 6);
  // Pixel centres at integers: x maps to 2 x + 0.5.
  EXPECT_NEAR(c.fx, 2 * kFocal, 0.01 * kFocal);
  EXPECT_NEAR(c.fy, 2 * kFocal, 0.01 * kFocal);
  EXPECT_NEAR(c.cx, 2 * kCx + 0.5, 4.0);
  EXPECT_NEAR(c.cy, 2 * kCy + 0.5, 4.0);
  EXPECT_NEAR(c.k1, kK1, 0.01);
  EXPECT_LT(c.rms_px, 0.5);
  std::cout << "at 2x: fx " << c.fx << " fy " << c.fy << " cx " << c.cx
            << " cy " << c.cy << " k1 " << c.k1 << " rms " << c.rms_px
            << " px\n";
}

TEST_F(CalibrationTest, UnreadableImagesAreRejectedWithAReason) {
  std::string junk = *extra_ + "/notes.png";
  std::ofstream(junk) << "not an image";
  std::vector<std::string> paths = {junk, (*views_)[0], (*views_)[1],
                                    (*views_)[2]};
  std::vector<std::string> rejected;
  auto c = calibrate_chessboard(paths, kBoard, kSquareM, &rejected);
  EXPECT_EQ(c.images_used, 3);
  ASSERT_EQ(rejected.size(), 1u);
  EXPECT_EQ(rejected[0], junk + ": not a readable image");
}

TEST_F(CalibrationTest, FewerThanThreeViewsThrow) {
  std::vector<std::string> rejected;
  try {
    calibrate_chessboard({(*views_)[0], *blank_, (*views_)[1]}, kBoard,
                         kSquareM, &rejected);
    FAIL() << "expected std::runtime_error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("at least 3"), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("found it in 2 of 3"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(rejected.size(), 1u);
  EXPECT_THROW(calibrate_chessboard({}, kBoard, kSquareM, nullptr),
               std::runtime_error);
}

TEST_F(CalibrationTest, ImagesOfDifferentSizesThrow) {
  cv::Mat small;
  cv::resize(cv::imread((*views_)[1]), small, cv::Size(640, 480));
  std::string other = write_png(*extra_, "small.png", small);
  try {
    calibrate_chessboard({(*views_)[0], other, (*views_)[2], (*views_)[3]},
                         kBoard, kSquareM, nullptr);
    FAIL() << "expected std::runtime_error";
  } catch (const std::runtime_error& e) {
    std::string what = e.what();
    EXPECT_NE(what.find("differ in size"), std::string::npos) << what;
    EXPECT_NE(what.find("1280x960"), std::string::npos) << what;
    EXPECT_NE(what.find("640x480"), std::string::npos) << what;
  }
}

TEST(CalibrationBoard, ParsesInnerCornerCounts) {
  auto b = parse_board_size("9x6");
  ASSERT_TRUE(b);
  EXPECT_EQ(b->cols, 9);
  EXPECT_EQ(b->rows, 6);
  EXPECT_TRUE(parse_board_size("7X7"));
  for (const char* bad : {"", "9", "9x", "x6", "2x6", "9x2", "9x6x3", "-9x6",
                          "9 x 6", "101x6", "9.0x6", "abcxdef"})
    EXPECT_FALSE(parse_board_size(bad)) << bad;
  EXPECT_THROW(calibrate_chessboard({}, BoardSize{2, 6}, 0.025, nullptr),
               std::invalid_argument);
  EXPECT_THROW(calibrate_chessboard({}, kBoard, 0.0, nullptr),
               std::invalid_argument);
}

Json good_camera() {
  CameraCalibration c;
  c.width = 1280;
  c.height = 960;
  c.fx = c.fy = 1000;
  c.cx = 640;
  c.cy = 480;
  c.k1 = -0.1;
  c.rms_px = 0.1;
  c.images_used = 10;
  return to_json(c);
}

TEST(CalibrationJson, DocumentFormMatchesTheApi) {
  Json j = good_camera();
  EXPECT_EQ(j["fx"], 1000.0);
  EXPECT_EQ(j["width"], 1280);
  EXPECT_EQ(j["distortion"], Json::parse("[-0.1, 0, 0, 0, 0]"));
  EXPECT_EQ(j["source"], "calibrated");
  EXPECT_EQ(j["rms_px"], 0.1);
  EXPECT_EQ(j["images_used"], 10);
  EXPECT_EQ(documents::validate_camera(j), "");
}

TEST(CalibrationJson, AcceptsMinimalAndExtendedDocuments) {
  Json exif = Json::parse(R"({"fx": 2800, "fy": 2800.5, "cx": 1632,
      "cy": 1224, "width": 3264, "height": 2448.0, "source": "exif"})");
  EXPECT_EQ(documents::validate_camera(exif), "");
  exif["distortion"] = Json::array();
  exif["model"] = "Pixel 8";
  EXPECT_EQ(documents::validate_camera(exif), "");
  // OpenCV's eight terms, the rational ones zero (docs/api.md).
  exif["distortion"] = Json::parse("[0.1, -0.2, 0, 0, 0.01, 0, 0, 0]");
  exif["source"] = "estimated";
  EXPECT_EQ(documents::validate_camera(exif), "");
}

// Each (field, bad value) must be refused with a message naming the field.
TEST(CalibrationJson, RejectsEachBadFieldByName) {
  const double nan = std::nan("");
  const std::vector<std::pair<std::string, Json>> bad = {
      {"fx", 0},
      {"fx", -1000},
      {"fx", "1000"},
      {"fx", nan},
      {"fy", 0},
      {"fy", Json()},
      {"width", 0},
      {"width", 1280.5},
      {"width", -1280},
      {"height", 0},
      {"height", "960"},
      {"cx", -1},
      {"cx", 1281},
      {"cx", nan},
      {"cy", 961},
      {"cy", -0.5},
      {"distortion", 0.1},
      {"distortion", "[]"},
      {"distortion", Json::array({0, 0, 0, 0, 0, 0, 0, 0, 0})},
      {"distortion", Json::array({0, 0, 0, 0, 0, 0, 0, 0.3})},
      {"source", "guess"},
      {"source", 1},
      {"rms_px", -0.1},
      {"rms_px", "low"},
      {"images_used", 2.5},
      {"images_used", -1},
  };
  for (const auto& [field, value] : bad) {
    Json j = good_camera();
    j[field] = value;
    std::string problem = documents::validate_camera(j);
    EXPECT_NE(problem.find(field), std::string::npos)
        << field << "=" << j[field].dump() << " gave '" << problem << "'";
  }
  Json with_inf = good_camera();
  with_inf["distortion"][2] = std::numeric_limits<double>::infinity();
  // nlohmann stores infinity as a number, which JSON text cannot carry; the
  // handler may still meet it from code.
  EXPECT_NE(documents::validate_camera(with_inf).find("distortion[2]"),
            std::string::npos);
  for (const char* field :
       {"fx", "fy", "cx", "cy", "width", "height", "source"}) {
    Json j = good_camera();
    j.erase(field);
    EXPECT_NE(documents::validate_camera(j).find(field), std::string::npos)
        << "missing " << field;
  }
  EXPECT_NE(documents::validate_camera(Json::array()), "");
}

TEST_F(CalibrationTest, CliWritesTheCameraDocument) {
  std::string out = arscout::testing::make_temp_dir("calibration-cli");
  std::string url = "sqlite:" + out + "/x.db";
  std::string log = out + "/log.txt";
  int code = run_cli("calibrate --images '" + *dir_ +
                         "' --board 9x6 --square 0.025 --camera-id cam1 "
                         "--db '" +
                         url + "'",
                     log);
  std::string output = arscout::testing::slurp(log);
  ASSERT_EQ(code, 0) << output;
  EXPECT_NE(output.find("board found  view-00.png"), std::string::npos)
      << output;
  EXPECT_NE(output.find("rejected     blank.png"), std::string::npos) << output;
  EXPECT_NE(output.find("RMS reprojection error"), std::string::npos) << output;

  auto store = arscout::db::Store::open(url);
  auto doc = store->get("/cameras/cam1");
  ASSERT_TRUE(doc);
  EXPECT_EQ(doc->kind, "camera");
  const Json& a = doc->attrs;
  EXPECT_EQ(documents::validate_camera(a), "") << a.dump();
  EXPECT_NEAR(a["fx"].get<double>(), kFocal, 0.005 * kFocal);
  EXPECT_NEAR(a["cy"].get<double>(), kCy, 2.0);
  EXPECT_EQ(a["width"], kWidth);
  EXPECT_EQ(a["images_used"], 10);
  EXPECT_LT(a["rms_px"].get<double>(), 0.5);
  EXPECT_NEAR(a["distortion"][0].get<double>(), kK1, 0.01);
  std::error_code ignored;
  fs::remove_all(out, ignored);
}

// The same through the API: an in-process server, a scout's token.
TEST_F(CalibrationTest, CliPutsTheCameraOverHttp) {
  std::string out = arscout::testing::make_temp_dir("calibration-http");
  auto store = arscout::db::Store::open("sqlite:" + out + "/x.db");
  std::string token = create_token(*store, Role::kScout, "alice");
  ServerOptions options;
  options.port = 0;
  Server server(*store, options);
  server.start();
  std::string args = "calibrate --images '" + *dir_ +
                     "' --board 9x6 --square 0.025 --camera-id phone-1 "
                     "--server http://127.0.0.1:" +
                     std::to_string(server.port()) + " --token ";
  std::string log = out + "/log.txt";

  int code = run_cli(args + token, log);
  ASSERT_EQ(code, 0) << arscout::testing::slurp(log);
  EXPECT_NE(arscout::testing::slurp(log).find("(HTTP 201)"), std::string::npos)
      << arscout::testing::slurp(log);
  // alice's camera id is her own (docs/api.md), and the CLI says where.
  EXPECT_NE(arscout::testing::slurp(log).find("stored /cameras/alice.phone-1"),
            std::string::npos)
      << arscout::testing::slurp(log);
  auto doc = store->get("/cameras/alice.phone-1");
  ASSERT_TRUE(doc);
  EXPECT_EQ(doc->kind, "camera");
  EXPECT_NEAR(doc->attrs["fx"].get<double>(), kFocal, 0.005 * kFocal);
  EXPECT_EQ(doc->attrs["source"], "calibrated");

  // A refused token fails with the server's message and changes nothing.
  code = run_cli(args + "ars_not_a_token", log);
  EXPECT_EQ(code, 2) << arscout::testing::slurp(log);
  EXPECT_NE(arscout::testing::slurp(log).find("HTTP 401"), std::string::npos)
      << arscout::testing::slurp(log);
  EXPECT_EQ(store->get("/cameras/alice.phone-1")->version, 1);
  server.stop();
  std::error_code ignored;
  fs::remove_all(out, ignored);
}

TEST_F(CalibrationTest, CliRefusesABadBoardAsUsage) {
  std::string out = arscout::testing::make_temp_dir("calibration-cli");
  std::string log = out + "/log.txt";
  int code = run_cli("calibrate --images '" + *dir_ +
                         "' --board 9by6 --square 0.025 --camera-id cam1",
                     log);
  EXPECT_EQ(code, 2) << arscout::testing::slurp(log);
  EXPECT_NE(arscout::testing::slurp(log).find("--board"), std::string::npos);
  code = run_cli("calibrate --images '" + *dir_ +
                     "' --board 9x6 --square 0.025 --camera-id 'a/b'",
                 log);
  EXPECT_EQ(code, 2) << arscout::testing::slurp(log);

  // Too few photos with the board is bad input too.
  fs::copy_file((*views_)[0], out + "/view.png");
  fs::copy_file(*blank_, out + "/blank.png");
  code = run_cli("calibrate --images '" + out +
                     "' --board 9x6 --square 0.025 --camera-id cam1",
                 log);
  EXPECT_EQ(code, 2) << arscout::testing::slurp(log);
  EXPECT_NE(arscout::testing::slurp(log).find("found it in 1 of 2"),
            std::string::npos)
      << arscout::testing::slurp(log);
  std::error_code ignored;
  fs::remove_all(out, ignored);
}

}  // namespace
}  // namespace arscout::ingest
