// The viewer's pieces on synthetic data with exact answers: the projection
// the overlay draws with, the overlay's z-buffer and depth colours, the tar
// writer, and the ECEF PLY.
#include <array>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include <gtest/gtest.h>
#include <Eigen/Geometry>
#include <opencv2/calib3d.hpp>

#include "arscout/util/error.h"
#include "arscout/viewer/exporter.h"
#include "arscout/viewer/exports.h"
#include "arscout/viewer/overlay.h"
#include "tar_writer.h"
#include "test_stores.h"
#include "tool_process.h"

namespace arscout::viewer {
namespace {

namespace fs = std::filesystem;

ImageCamera test_camera() {
  ImageCamera c;
  c.intrinsics.width = 640;
  c.intrinsics.height = 480;
  c.intrinsics.fx = 500;
  c.intrinsics.fy = 510;
  c.intrinsics.cx = 322;
  c.intrinsics.cy = 241;
  return c;
}

// test_camera() with a lens: OpenCV's radial and tangential coefficients.
ImageCamera with_lens(double k1, double k2, double p1, double p2, double k3) {
  ImageCamera c = test_camera();
  c.intrinsics.k1 = k1;
  c.intrinsics.k2 = k2;
  c.intrinsics.p1 = p1;
  c.intrinsics.p2 = p2;
  c.intrinsics.k3 = k3;
  return c;
}

TEST(ViewerProject, AgreesWithOpenCvIncludingDistortion) {
  ImageCamera camera = with_lens(-0.12, 0.03, 0.001, -0.002, 0.004);
  camera.R = Eigen::AngleAxisd(0.3, Eigen::Vector3d(0.2, 1, 0.1).normalized())
                 .toRotationMatrix();
  camera.t = Eigen::Vector3d(0.5, -0.2, 4);
  const engine::CameraIntrinsics& k = camera.intrinsics;
  const cv::Matx33d K(k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
  const std::vector<double> dist{k.k1, k.k2, k.p1, k.p2, k.k3};
  cv::Matx33d R;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) R(r, c) = camera.R(r, c);
  cv::Vec3d rvec;
  cv::Rodrigues(R, rvec);
  const cv::Vec3d tvec(camera.t.x(), camera.t.y(), camera.t.z());
  for (double x = -1.5; x <= 1.5; x += 0.75)
    for (double y = -1; y <= 1; y += 0.5) {
      const std::vector<cv::Point3d> world{{x, y, 0.3 * x * y}};
      std::vector<cv::Point2d> expected;
      cv::projectPoints(world, rvec, tvec, K, dist, expected);
      const auto got = project(camera, {world[0].x, world[0].y, world[0].z});
      ASSERT_TRUE(got);
      EXPECT_NEAR(got->x(), expected[0].x, 1e-6);
      EXPECT_NEAR(got->y(), expected[0].y, 1e-6);
    }
  // Behind the camera: nothing.
  EXPECT_FALSE(project(
      camera, -camera.R.transpose() * camera.t - camera.R.transpose().col(2)));
}

// Two walls facing the camera: a near one over the left half of the view,
// a far one over all of it, both sampled sparsely enough to leave gaps
// between splats.
std::vector<engine::ColoredPoint> two_walls(const ImageCamera& c) {
  std::vector<engine::ColoredPoint> points;
  auto wall = [&](double z, double u_from, double u_to) {
    for (double v = 0; v < c.intrinsics.height; v += 2.5)
      for (double u = u_from; u < u_to; u += 2.5)
        points.push_back(
            {static_cast<float>((u - c.intrinsics.cx) / c.intrinsics.fx * z),
             static_cast<float>((v - c.intrinsics.cy) / c.intrinsics.fy * z),
             static_cast<float>(z), 200, 200, 200});
  };
  wall(4, 0, 320);
  wall(12, 0, 640);
  return points;
}

TEST(ViewerOverlay, NearPointsHideFarOnesAndAreColouredWarm) {
  const ImageCamera camera = test_camera();
  const cv::Mat photo(480, 640, CV_8UC3, cv::Scalar(128, 128, 128));
  OverlayOptions options;
  options.opacity = 1;
  options.radius = 1;
  const cv::Mat out = draw_overlay(photo, camera, two_walls(camera), options);
  ASSERT_EQ(out.size(), photo.size());
  // Turbo: near (red) has more red than blue, far (blue) the opposite.
  int near_ok = 0, far_ok = 0, left = 0, right = 0;
  for (int y = 20; y < 460; ++y) {
    for (int x = 20; x < 300; ++x, ++left) {
      const cv::Vec3b p = out.at<cv::Vec3b>(y, x);
      near_ok += p[2] > p[0] + 60;
    }
    for (int x = 340; x < 620; ++x, ++right) {
      const cv::Vec3b p = out.at<cv::Vec3b>(y, x);
      far_ok += p[0] > p[2] + 60;
    }
  }
  // Every pixel of the near wall is near-coloured: the far wall does not
  // show through the gaps between its splats.
  EXPECT_GT(near_ok, 0.99 * left);
  EXPECT_GT(far_ok, 0.99 * right);
  // A smaller output keeps the geometry: the boundary stays at the middle.
  options.max_side = 320;
  const cv::Mat small = draw_overlay(photo, camera, two_walls(camera), options);
  ASSERT_EQ(small.size(), cv::Size(320, 240));
  const cv::Vec3b l = small.at<cv::Vec3b>(120, 150),
                  r = small.at<cv::Vec3b>(120, 170);
  EXPECT_GT(l[2], l[0]);
  EXPECT_GT(r[0], r[2]);
}

// The scout's overlay draws only confident fused points: a near wall of
// points only one depth map measured is left out (the far wall shows where
// it was), unless min_support is 0; sparse points (support 0) always show.
TEST(ViewerOverlay, LowConfidencePointsAreNotDrawn) {
  const ImageCamera camera = test_camera();
  const cv::Mat photo(480, 640, CV_8UC3, cv::Scalar(128, 128, 128));
  std::vector<engine::ColoredPoint> points = two_walls(camera);
  std::vector<engine::ColoredPoint> shifted = points;
  // The far wall's right half once more, at 3 m (nearer than the near
  // wall), measured by one depth map.
  for (engine::ColoredPoint& p : shifted) p.support = 5;
  std::vector<engine::ColoredPoint> floaters;
  for (engine::ColoredPoint p : points) {
    if (p.z < 11 || p.x < 0) continue;
    p.support = 1;
    p.x *= 0.25f, p.y *= 0.25f, p.z *= 0.25f;  // on the same rays
    floaters.push_back(p);
  }
  ASSERT_GT(floaters.size(), 1000u);
  shifted.insert(shifted.end(), floaters.begin(), floaters.end());
  OverlayOptions options;
  options.opacity = 1;
  options.radius = 1;
  const cv::Mat confident = draw_overlay(photo, camera, shifted, options);
  const cv::Mat without =
      draw_overlay(photo, camera, two_walls(camera), options);
  // Colours follow the drawn depth range, so the same points give the same
  // picture only if the floaters were left out.
  EXPECT_EQ(cv::norm(confident, without, cv::NORM_INF), 0);
  options.min_support = 0;
  const cv::Mat all = draw_overlay(photo, camera, shifted, options);
  EXPECT_GT(cv::norm(all, without, cv::NORM_INF), 0);
  // Sparse points (support 0) are drawn whatever min_support.
  options.min_support = 200;
  const cv::Mat sparse =
      draw_overlay(photo, camera, two_walls(camera), options);
  EXPECT_EQ(cv::norm(sparse, without, cv::NORM_INF), 0);
}

// A quad of one colour at depth z over x in [x0, x1], y in [y0, y1]
// (camera frame of test_camera: the identity pose).
engine::TexturedMesh flat_quad(double z, double x0, double x1, double y0,
                               double y1, std::array<std::uint8_t, 3> rgb) {
  engine::TexturedMesh quad;
  for (const auto& [x, y] : {std::pair{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}}) {
    quad.positions.emplace_back(x, y, z);
    quad.colors.push_back(rgb);
  }
  quad.indices = {0, 1, 2, 0, 2, 3};
  return quad;
}

// The mesh overlay: the nearest surface wins whatever the meshes' order,
// the lens's distortion bends the drawn edge where project() puts it, and
// where no surface is seen the photo stays.
TEST(ViewerOverlay, MeshIsDrawnThroughTheLensNearestFirst) {
  const ImageCamera camera = with_lens(-0.2, 0.02, 0.001, 0, 0);
  const cv::Mat photo(480, 640, CV_8UC3, cv::Scalar(128, 128, 128));
  // A red near wall whose right edge is at normalised x 0.476 (pixel 560 of
  // a pinhole, about 549 through this lens); a blue far wall behind it
  // over the lower 3/4 of the view; nothing above.
  const double edge = 0.476 * 4;
  const engine::TexturedMesh near =
      flat_quad(4, -10, edge, -0.8, 10, {255, 0, 0});
  const engine::TexturedMesh far =
      flat_quad(12, -40, 40, -2.4, 40, {0, 0, 255});
  OverlayOptions options;
  options.opacity = 1;
  const cv::Mat a = draw_mesh_overlay(photo, camera, {near, far}, options);
  const cv::Mat b = draw_mesh_overlay(photo, camera, {far, near}, options);
  ASSERT_EQ(a.size(), photo.size());
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0);
  int checked = 0;
  for (double y = -0.6; y <= 3; y += 0.3) {
    const auto at = project(camera, {edge, y, 4});
    ASSERT_TRUE(at);
    const int u = static_cast<int>(std::lround(at->x()));
    const int v = static_cast<int>(std::lround(at->y()));
    if (v < 0 || v >= 480) continue;
    const cv::Vec3b inside = a.at<cv::Vec3b>(v, u - 3);  // BGR
    const cv::Vec3b outside = a.at<cv::Vec3b>(v, u + 3);
    EXPECT_GT(inside[2], 200) << "at " << u - 3 << ", " << v;
    EXPECT_LT(inside[0], 50) << "at " << u - 3 << ", " << v;
    EXPECT_GT(outside[0], 200) << "at " << u + 3 << ", " << v;
    EXPECT_LT(outside[2], 50) << "at " << u + 3 << ", " << v;
    ++checked;
  }
  EXPECT_GE(checked, 8);
  // Above both walls the photo is untouched.
  EXPECT_EQ(a.at<cv::Vec3b>(5, 320), cv::Vec3b(128, 128, 128));
  // Half opacity: half the photo's grey.
  options.opacity = 0.5;
  const cv::Mat half = draw_mesh_overlay(photo, camera, {near, far}, options);
  EXPECT_NEAR(half.at<cv::Vec3b>(240, 100)[2], (255 + 128) / 2.0, 1.5);
}

TEST(ViewerTar, GnuTarListsAndExtractsTheFiles) {
  TarWriter tar;
  std::string big(1500, 'x');
  big[700] = '\n';
  tar.add("site/cameras.txt", "# cameras\n1 PINHOLE 640 480 1 2 3 4\n",
          1700000000);
  tar.add("site/empty.txt", "", 1700000000);
  tar.add("site/points3D.txt", big, 1700000000);
  EXPECT_THROW(tar.add(std::string(101, 'a'), "", 0), std::invalid_argument);
  const std::string bytes = tar.finish();
  EXPECT_EQ(bytes.size() % 512, 0u);
  const fs::path dir = testing::make_temp_dir("tar");
  std::ofstream(dir / "a.tar", std::ios::binary) << bytes;
  const std::string listing = testing::command_output(
      "tar -tvf '" + (dir / "a.tar").string() + "' 2>&1");
  EXPECT_NE(listing.find("site/cameras.txt"), std::string::npos) << listing;
  EXPECT_NE(listing.find("2023-11-14"), std::string::npos) << listing;
  ASSERT_EQ(std::system(("tar -xf '" + (dir / "a.tar").string() + "' -C '" +
                         dir.string() + "'")
                            .c_str()),
            0);
  std::ostringstream got;
  got << std::ifstream(dir / "site/points3D.txt").rdbuf();
  EXPECT_EQ(got.str(), big);
  EXPECT_TRUE(fs::exists(dir / "site/empty.txt"));
  EXPECT_EQ(fs::file_size(dir / "site/empty.txt"), 0u);
}

// WGS84 geodetic to ECEF, written out here so the export is checked
// against more than the function it uses.
Eigen::Vector3d ecef_of(double lat_deg, double lon_deg, double h) {
  const double a = 6378137.0, f = 1 / 298.257223563, e2 = f * (2 - f);
  const double lat = lat_deg * M_PI / 180, lon = lon_deg * M_PI / 180;
  const double n = a / std::sqrt(1 - e2 * std::sin(lat) * std::sin(lat));
  return {(n + h) * std::cos(lat) * std::cos(lon),
          (n + h) * std::cos(lat) * std::sin(lon),
          (n * (1 - e2) + h) * std::sin(lat)};
}

TEST(ViewerEcefPly, DoublesInEcefWithTheColours) {
  const engine::Geodetic origin{46.519, 6.5666, 400.0};
  const std::vector<engine::ColoredPoint> enu{
      {0, 0, 0, 10, 20, 30}, {0, 0, 100, 1, 2, 3}, {1000, 0, 0, 4, 5, 6}};
  const std::string bytes = encode_ecef_ply(enu, origin, "test frame");
  const size_t end = bytes.find("end_header\n");
  ASSERT_NE(end, std::string::npos);
  const std::string header = bytes.substr(0, end);
  EXPECT_NE(header.find("element vertex 3\n"), std::string::npos);
  EXPECT_NE(header.find("property double x\n"), std::string::npos);
  EXPECT_NE(header.find("comment test frame\n"), std::string::npos);
  const char* body = bytes.data() + end + 11;
  ASSERT_EQ(bytes.size() - end - 11, 3u * 27);
  std::vector<Eigen::Vector3d> xyz;
  for (int i = 0; i < 3; ++i) {
    double v[3];
    std::memcpy(v, body + 27 * i, sizeof v);
    xyz.emplace_back(v[0], v[1], v[2]);
  }
  EXPECT_LT((xyz[0] - ecef_of(origin.lat, origin.lon, origin.alt)).norm(),
            1e-6);
  EXPECT_LT((xyz[1] - ecef_of(origin.lat, origin.lon, origin.alt + 100)).norm(),
            1e-6);
  EXPECT_NEAR((xyz[2] - xyz[0]).norm(), 1000, 1e-6);
  EXPECT_EQ(static_cast<uint8_t>(body[24]), 10);
  EXPECT_EQ(static_cast<uint8_t>(body[27 + 26]), 3);
  EXPECT_THROW(encode_ecef_ply(enu, origin, "two\nlines"),
               std::invalid_argument);
}

// The registry (exporter.h): the formats users' scripts name are there,
// each found by its name and described for --help, GET /v1/exports and the
// viewer.
TEST(ExportRegistry, EveryFormatIsFoundByItsNameAndDescribed) {
  std::set<std::string_view> names;
  for (const Exporter* e : exporters()) {
    EXPECT_TRUE(names.insert(e->name).second) << e->name << " twice";
    EXPECT_EQ(find_exporter(e->name), e);
    EXPECT_EQ(e->extension.substr(0, 1), ".") << e->name;
    EXPECT_NE(e->mime_type.find('/'), std::string_view::npos) << e->name;
    EXPECT_FALSE(e->summary.empty()) << e->name;
    EXPECT_NE(e->write, nullptr) << e->name;
  }
  for (const char* name : {"ply", "colmap", "geocsv", "ecef-ply", "las",
                           "3dtiles", "geojson", "glb", "obj", "3dtiles-mesh"})
    EXPECT_TRUE(names.count(name)) << name;
  EXPECT_FALSE(find_exporter("PLY"));
  EXPECT_FALSE(find_exporter(""));
  EXPECT_EQ(exporter_names(" | ").substr(0, 12), "ply | colmap");
}

TEST(ExportRegistry, AnUnknownFormatIsRefusedNamingTheFormats) {
  auto store = db::Store::open(testing::fresh_sqlite_url());
  try {
    export_site(*store, "s1", "stl");
    FAIL() << "an unknown format was exported";
  } catch (const util::Error& e) {
    EXPECT_EQ(e.kind(), util::ErrorKind::kInvalidArgument);
    const std::string what = e.what();
    EXPECT_NE(what.find("'stl'"), std::string::npos) << what;
    for (const Exporter* format : exporters())
      EXPECT_NE(what.find(format->name), std::string::npos) << what;
  }
}

}  // namespace
}  // namespace arscout::viewer
