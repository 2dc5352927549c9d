// The COLMAP text model: write_colmap_text then read_colmap_text gives the
// model back (poses to the bit, pixel coordinates to the last bits of the
// 0.5 pixel shift), models in COLMAP's other camera models read, and every
// malformed or inconsistent file is refused naming its path and line.
#include "arscout/engine/model_io.h"

#include <unistd.h>

#include <Eigen/Geometry>
#include <bit>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <gtest/gtest.h>

#include "arscout/engine/ply.h"

namespace arscout::engine {
namespace {

namespace fs = std::filesystem;

uint64_t bits(double value) { return std::bit_cast<uint64_t>(value); }

// Relative 1e-12: the 0.5 pixel shift may cost the last bit.
void expect_close(double expected, double actual) {
  EXPECT_NEAR(actual, expected, 1e-12 * std::max(1.0, std::abs(expected)));
}

ModelImage make_image(std::string id, int camera, Eigen::Quaterniond q,
                      Eigen::Vector3d t) {
  q.normalize();
  ModelImage image;
  image.id = std::move(id);
  image.camera = camera;
  image.qvec = {q.w(), q.x(), q.y(), q.z()};
  image.tvec = {t.x(), t.y(), t.z()};
  const Eigen::Vector3d c = -(q.conjugate() * t);
  image.centre = {c.x(), c.y(), c.z()};
  return image;
}

// Observes point `id` (or none for -1) at pixel (x, y).
void add_keypoint(ModelImage& image, double x, double y, int64_t id) {
  image.keypoints.push_back({x, y});
  image.point_ids.push_back(id);
}

// Two cameras (one distorted, with k3), three images, five points with
// non-consecutive ids; every number has many significant digits.
Model small_model() {
  Model model;
  CameraIntrinsics plain;
  plain.width = 1920;
  plain.height = 1080;
  plain.fx = plain.fy = 1534.123456789012;
  plain.cx = 959.3141592653589;
  plain.cy = 539.2718281828459;
  CameraIntrinsics distorted = plain;
  distorted.width = 4000;
  distorted.height = 3000;
  distorted.fy = 1537.000000000123;
  distorted.cx = 2001.000000001;
  distorted.cy = 1499.5;
  distorted.k1 = -0.123456789012345;
  distorted.k2 = 0.0345678901234567;
  distorted.p1 = 1.234567890123e-4;
  distorted.p2 = -9.87654321e-5;
  distorted.k3 = -0.00123456789;
  model.cameras = {{"cam-a", plain}, {"cam-b", distorted}};

  model.images = {
      make_image("IMG_0001.JPG", 0, Eigen::Quaterniond(0.9, 0.1, -0.2, 0.3),
                 {0.123456789, -1.98765432101, 3.3}),
      make_image("photo two.jpg", 1, Eigen::Quaterniond(-0.3, 0.7, 0.1, 0.05),
                 {-12.5, 1e-7, 0.333333333333333}),
      make_image("c-3", 0, Eigen::Quaterniond(1, 0, 0, 0), {0, 0, 0})};
  // Point ids 0, 3, 7, 8, 41 (COLMAP 1, 4, 8, 9, 42).
  add_keypoint(model.images[0], 10.25, 20.125, 0);
  add_keypoint(model.images[0], 1919.4, 0.3333333333333, 3);
  add_keypoint(model.images[0], 500, 500, -1);
  add_keypoint(model.images[0], 777.777777777, 333.3, 7);
  add_keypoint(model.images[1], -0.4, -0.25, 0);
  add_keypoint(model.images[1], 3999.49, 2999.49, 8);
  add_keypoint(model.images[1], 1234.5678, 2345.6789, 3);
  add_keypoint(model.images[2], 1, 2, 41);
  add_keypoint(model.images[2], 3, 4, 7);
  add_keypoint(model.images[2], 5, 6, -1);

  auto point = [](int64_t id, std::array<double, 3> xyz,
                  std::array<uint8_t, 3> rgb, double error,
                  std::vector<std::pair<int, int>> track) {
    return ModelPoint{id, xyz, rgb, error, std::move(track)};
  };
  model.points = {
      point(0, {1.5, -2.25, 10.125}, {255, 0, 17}, 0.5, {{0, 0}, {1, 0}}),
      point(3, {-0.1, 0.2, -0.3}, {1, 2, 3}, 1.25e-3, {{0, 1}, {1, 2}}),
      point(7, {1e6, -1e-9, 43.5}, {0, 0, 0}, 2.0, {{0, 3}, {2, 1}}),
      point(8, {3.14159265358979, 2.71828182845905, 1.41421356237310},
            {128, 128, 128}, 0.75, {{1, 1}}),
      point(41, {-7, 8, -9}, {9, 99, 199}, 0, {{2, 0}})};
  double sum = 0;
  size_t count = 0;
  for (const ModelPoint& p : model.points) {
    sum += p.error_px * p.track.size();
    count += p.track.size();
  }
  model.mean_reprojection_px = sum / count;
  return model;
}

void expect_same_camera(const CameraIntrinsics& a, const CameraIntrinsics& b) {
  EXPECT_EQ(a.width, b.width);
  EXPECT_EQ(a.height, b.height);
  for (auto field :
       {&CameraIntrinsics::fx, &CameraIntrinsics::fy, &CameraIntrinsics::k1,
        &CameraIntrinsics::k2, &CameraIntrinsics::p1, &CameraIntrinsics::p2,
        &CameraIntrinsics::k3}) {
    EXPECT_EQ(bits(a.*field), bits(b.*field));
  }
  expect_close(a.cx, b.cx);
  expect_close(a.cy, b.cy);
}

void expect_same_image(const ModelImage& a, const ModelImage& b) {
  EXPECT_EQ(a.id, b.id);
  EXPECT_EQ(a.camera, b.camera);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(bits(a.qvec[i]), bits(b.qvec[i]));
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(bits(a.tvec[i]), bits(b.tvec[i]));
    expect_close(a.centre[i], b.centre[i]);
  }
  EXPECT_FALSE(b.geodetic);
  ASSERT_EQ(a.keypoints.size(), b.keypoints.size());
  for (size_t k = 0; k < a.keypoints.size(); ++k) {
    expect_close(a.keypoints[k][0], b.keypoints[k][0]);
    expect_close(a.keypoints[k][1], b.keypoints[k][1]);
  }
  EXPECT_EQ(a.point_ids, b.point_ids);
}

void expect_same_point(const ModelPoint& a, const ModelPoint& b) {
  EXPECT_EQ(a.id, b.id);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(bits(a.xyz[i]), bits(b.xyz[i]));
  EXPECT_EQ(a.rgb, b.rgb);
  EXPECT_EQ(bits(a.error_px), bits(b.error_px));
  EXPECT_EQ(a.track, b.track);
}

class ModelIoTest : public ::testing::Test {
 protected:
  void SetUp() override {
    // Per process and test: other test runs may share the temp directory.
    dir_ = (fs::temp_directory_path() /
            ("arscout_model_io_test_" + std::to_string(::getpid()) + "_" +
             ::testing::UnitTest::GetInstance()->current_test_info()->name()))
               .string();
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  void write(const std::string& name, const std::string& text) {
    std::ofstream(dir_ + "/" + name, std::ios::binary) << text;
  }
  std::string read(const std::string& name) {
    std::ifstream in(dir_ + "/" + name, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), {}};
  }
  // Replaces the last `old` on line `line` (1-based) of file `name`, or the
  // whole line when `old` is empty.
  void edit(const std::string& name, int line, const std::string& old,
            const std::string& replacement) {
    std::string text = read(name);
    size_t begin = 0;
    for (int i = 1; i < line; ++i) begin = text.find('\n', begin) + 1;
    const size_t end = text.find('\n', begin);
    ASSERT_NE(end, std::string::npos) << name << " has no line " << line;
    const std::string_view current(text.data() + begin, end - begin);
    const size_t at = old.empty() ? 0 : current.rfind(old);
    ASSERT_NE(at, std::string::npos) << old << " not on line " << line;
    text.replace(begin + at, old.empty() ? current.size() : old.size(),
                 replacement);
    write(name, text);
  }
  // read_colmap_text must fail with "DIR/NAME:LINE: ..." containing
  // `fragment`.
  void expect_error(const std::string& name, int line,
                    const std::string& fragment) {
    const std::string prefix =
        dir_ + "/" + name + ":" + std::to_string(line) + ": ";
    try {
      read_colmap_text(dir_);
      ADD_FAILURE() << "no error, expected " << prefix << "..." << fragment;
    } catch (const std::runtime_error& e) {
      const std::string what = e.what();
      EXPECT_EQ(what.rfind(prefix, 0), 0u) << what;
      EXPECT_NE(what.find(fragment), std::string::npos) << what;
    }
  }

  std::string dir_;
};

TEST_F(ModelIoTest, ColmapTextRoundTrips) {
  const Model model = small_model();
  write_colmap_text(model, dir_);
  const Model back = read_colmap_text(dir_);

  EXPECT_FALSE(back.geo_registered);
  EXPECT_FALSE(back.enu_origin);
  ASSERT_EQ(back.cameras.size(), 2u);
  EXPECT_EQ(back.cameras[0].id, "1");  // COLMAP ids, not our names
  EXPECT_EQ(back.cameras[1].id, "2");
  for (size_t i = 0; i < 2; ++i) {
    SCOPED_TRACE("camera " + std::to_string(i));
    expect_same_camera(model.cameras[i].intrinsics, back.cameras[i].intrinsics);
  }
  ASSERT_EQ(back.images.size(), model.images.size());
  for (size_t i = 0; i < model.images.size(); ++i) {
    SCOPED_TRACE("image " + std::to_string(i));
    expect_same_image(model.images[i], back.images[i]);
  }
  ASSERT_EQ(back.points.size(), model.points.size());
  for (size_t i = 0; i < model.points.size(); ++i) {
    SCOPED_TRACE("point " + std::to_string(i));
    expect_same_point(model.points[i], back.points[i]);
  }
  expect_close(model.mean_reprojection_px, back.mean_reprojection_px);

  // Written again, the files are the same bytes.
  const std::string cameras = read("cameras.txt");
  const std::string images = read("images.txt");
  const std::string points = read("points3D.txt");
  write_colmap_text(back, dir_);
  EXPECT_EQ(read("cameras.txt"), cameras);
  EXPECT_EQ(read("images.txt"), images);
  EXPECT_EQ(read("points3D.txt"), points);
}

TEST_F(ModelIoTest, EmptyModelAndImagesWithoutKeypointsRoundTrip) {
  write_colmap_text(Model{}, dir_);
  const Model empty = read_colmap_text(dir_);
  EXPECT_TRUE(empty.cameras.empty());
  EXPECT_TRUE(empty.images.empty());
  EXPECT_TRUE(empty.points.empty());
  EXPECT_EQ(empty.mean_reprojection_px, 0);

  Model model = small_model();
  model.points.clear();
  for (ModelImage& image : model.images) {
    image.keypoints.clear();
    image.point_ids.clear();
  }
  write_colmap_text(model, dir_);
  const Model back = read_colmap_text(dir_);
  ASSERT_EQ(back.images.size(), 3u);
  for (size_t i = 0; i < 3; ++i)
    expect_same_image(model.images[i], back.images[i]);
}

TEST_F(ModelIoTest, ReadsColmapCameraModelsAndSparseIds) {
  write("cameras.txt",
        "# Camera list with one line of data per camera:\r\n"
        "\r\n"
        "7 SIMPLE_PINHOLE 640 480 500 320.5 240.5\r\n"
        "9 PINHOLE 640 480 500 501 320 240\r\n"
        "11 SIMPLE_RADIAL 800 600 700 400.5 300.5 -0.1\r\n"
        "12 RADIAL 800 600 700 400.5 300.5 -0.1 0.02\r\n"
        "   13 FULL_OPENCV 10 20 1 2 3 4 5 6 7 8 9 0 0 0\r\n");
  write("images.txt",
        "# comment\n"
        "100 1 0 0 0 1 2 3 11 first image.png  \n"
        "10.5 20.5 5 30.5 40.5 -1\n"
        "\n"
        "# between images\n"
        "3 0 1 0 0 0 0 0 7 second.png\n"
        "\n");
  write("points3D.txt", "5 1 2 3 10 20 30 0.5 100 0\n");
  const Model model = read_colmap_text(dir_);

  ASSERT_EQ(model.cameras.size(), 5u);
  const CameraIntrinsics& simple = model.cameras[0].intrinsics;
  EXPECT_EQ(model.cameras[0].id, "7");
  EXPECT_EQ(simple.width, 640);
  EXPECT_EQ(simple.fx, 500);
  EXPECT_EQ(simple.fy, 500);
  EXPECT_EQ(simple.cx, 320);
  EXPECT_EQ(simple.cy, 240);
  EXPECT_FALSE(simple.has_distortion());
  const CameraIntrinsics& pinhole = model.cameras[1].intrinsics;
  EXPECT_EQ(pinhole.fy, 501);
  EXPECT_EQ(pinhole.cx, 319.5);
  EXPECT_EQ(model.cameras[2].intrinsics.k1, -0.1);
  EXPECT_EQ(model.cameras[2].intrinsics.k2, 0);
  EXPECT_EQ(model.cameras[3].intrinsics.k2, 0.02);
  const CameraIntrinsics& full = model.cameras[4].intrinsics;
  EXPECT_EQ(full.fx, 1);
  EXPECT_EQ(full.fy, 2);
  EXPECT_EQ(full.cx, 2.5);
  EXPECT_EQ(full.cy, 3.5);
  EXPECT_EQ(full.k1, 5);
  EXPECT_EQ(full.k2, 6);
  EXPECT_EQ(full.p1, 7);
  EXPECT_EQ(full.p2, 8);
  EXPECT_EQ(full.k3, 9);

  ASSERT_EQ(model.images.size(), 2u);
  EXPECT_EQ(model.images[0].id, "first image.png");
  EXPECT_EQ(model.images[0].camera, 2);
  EXPECT_EQ(model.images[0].centre, (std::array<double, 3>{-1, -2, -3}));
  EXPECT_EQ(model.images[0].keypoints,
            (std::vector<std::array<double, 2>>{{10, 20}, {30, 40}}));
  EXPECT_EQ(model.images[0].point_ids, (std::vector<int64_t>{4, -1}));
  EXPECT_EQ(model.images[1].camera, 0);
  EXPECT_TRUE(model.images[1].keypoints.empty());
  ASSERT_EQ(model.points.size(), 1u);
  EXPECT_EQ(model.points[0].id, 4);
  EXPECT_EQ(model.points[0].track, (std::vector<std::pair<int, int>>{{0, 0}}));
  EXPECT_EQ(model.mean_reprojection_px, 0.5);
}

TEST_F(ModelIoTest, MalformedCamerasAreRefusedWithTheirLine) {
  write_colmap_text(small_model(), dir_);
  const std::string good = read("cameras.txt");
  // Lines 1-3 are comments; the cameras are on lines 4 and 5.
  struct Case {
    std::string old, replacement, fragment;
  };
  const Case cases[] = {
      {"FULL_OPENCV", "THIN_PRISM_FISHEYE", "unsupported camera model"},
      {" 4000 ", " 0 ", "WIDTH out of range"},
      {" 4000 ", " 4000.5 ", "bad WIDTH '4000.5'"},
      {" 0 0 0", " 0 0.5 0", "rational distortion"},
      {" 0 0 0", " 0 0", "missing camera parameter"},
      {" 0 0 0", " 0 0 0 0", "unexpected text"},
      {"2 FULL", "1 FULL", "duplicate CAMERA_ID 1"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.old + " -> " + c.replacement);
    write("cameras.txt", good);
    edit("cameras.txt", 5, c.old, c.replacement);
    expect_error("cameras.txt", 5, c.fragment);
  }
  write("cameras.txt", "# only a comment\n1 PINHOLE 10 10 1 1 five 5\n");
  expect_error("cameras.txt", 2, "bad camera parameter 'five'");
}

TEST_F(ModelIoTest, MalformedImagesAreRefusedWithTheirLine) {
  write_colmap_text(small_model(), dir_);
  const std::string good = read("images.txt");
  // Lines 1-4 are comments; image k's lines are 5 + 2k and 6 + 2k.
  struct Case {
    std::string old, replacement;
    int line;
    std::string fragment;
  };
  const Case cases[] = {
      {" 2 photo two.jpg", " 3 photo two.jpg", 7, "unknown CAMERA_ID 3"},
      {" 2 photo two.jpg", " 2 ", 7, "missing NAME"},
      {" 2 photo two.jpg", " 2x photo two.jpg", 7, "bad CAMERA_ID '2x'"},
      {"3 ", "1 ", 9, "duplicate IMAGE_ID 1"},
      {" 4", " 0", 8, "bad POINT3D_ID 0"},
      {" 4", "", 8, "missing POINT3D_ID"},
      {" 4", " 4 1.5", 8, "missing Y"},
      {"500.5 500.5 -1", "500.5 500.5 99", 6,
       "POINT3D_ID 99 is not in points3D.txt"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.old + " -> " + c.replacement);
    write("images.txt", good);
    edit("images.txt", c.line, c.old, c.replacement);
    expect_error("images.txt", c.line, c.fragment);
  }
  // Without its last line, the last image has no POINTS2D line.
  write("images.txt", good.substr(0, good.rfind('\n', good.size() - 2)));
  expect_error("images.txt", 9, "missing POINTS2D line");
}

TEST_F(ModelIoTest, MalformedPointsAreRefusedWithTheirLine) {
  write_colmap_text(small_model(), dir_);
  const std::string good = read("points3D.txt");
  // Lines 1-3 are comments; point k is on line 4 + k. Point 42 (the last,
  // line 8) is seen by keypoint 0 of image 3.
  struct Case {
    std::string replacement;
    std::string fragment;
  };
  const Case cases[] = {
      {"42 -7 8 -9 9 99 199 0 4 0", "unknown IMAGE_ID 4 in track"},
      {"42 -7 8 -9 9 99 199 0 3 3", "POINT2D_IDX 3 out of range"},
      {"42 -7 8 -9 9 99 199 0 3 -1", "POINT2D_IDX -1 out of range"},
      {"42 -7 8 -9 9 99 199 0 3 1", "observes another point"},
      {"42 -7 8 -9 9 99 199 0 3", "missing POINT2D_IDX"},
      {"42 -7 8 -9 9 99 256 0 3 0", "colour out of range"},
      {"42 -7 8 -9 9 99 199", "missing ERROR"},
      {"42 -7 8 nine 9 99 199 0 3 0", "bad coordinate 'nine'"},
      {"-1 -7 8 -9 9 99 199 0 3 0", "bad POINT3D_ID -1"},
      {"1 -7 8 -9 9 99 199 0 3 0", "observes another point"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.replacement);
    write("points3D.txt", good);
    edit("points3D.txt", 8, "", c.replacement);
    expect_error("points3D.txt", 8, c.fragment);
  }
  // A duplicate id is seen as such once its observations agree.
  write("points3D.txt", good + "42 -7 8 -9 9 99 199 0\n");
  expect_error("points3D.txt", 9, "duplicate POINT3D_ID 42");
}

TEST_F(ModelIoTest, MissingFilesAreNamed) {
  write_colmap_text(small_model(), dir_);
  fs::remove(dir_ + "/points3D.txt");
  try {
    read_colmap_text(dir_);
    ADD_FAILURE() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()), dir_ + "/points3D.txt: cannot read");
  }
}

TEST_F(ModelIoTest, PointsPlyHoldsThePointsAndTheFrame) {
  Model model = small_model();
  model.points[2].xyz[0] = 1e300;  // beyond float: infinite, not undefined
  write_points_ply(model, dir_ + "/sparse.ply");
  const std::vector<ColoredPoint> points = read_ply(dir_ + "/sparse.ply");
  ASSERT_EQ(points.size(), model.points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    const ModelPoint& p = model.points[i];
    EXPECT_EQ(points[i].x, static_cast<float>(i == 2 ? INFINITY : p.xyz[0]));
    EXPECT_EQ(points[i].y, static_cast<float>(p.xyz[1]));
    EXPECT_EQ(points[i].z, static_cast<float>(p.xyz[2]));
    EXPECT_EQ(points[i].r, p.rgb[0]);
    EXPECT_EQ(points[i].g, p.rgb[1]);
    EXPECT_EQ(points[i].b, p.rgb[2]);
  }
  const std::string bytes = read("sparse.ply");
  EXPECT_NE(bytes.find("\ncomment arscout sparse model, world frame local\n"),
            std::string::npos);
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_), {}), 1);  // no temp

  model.geo_registered = true;
  write_points_ply(model, dir_ + "/sparse.ply");
  EXPECT_NE(read("sparse.ply").find("world frame ENU\n"), std::string::npos);
}

}  // namespace
}  // namespace arscout::engine
