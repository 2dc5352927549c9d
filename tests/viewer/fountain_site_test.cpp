// The viewer's outputs on a real site: fountain-P11 as the scouts and the
// engine built it (the viewer_fountain fixture, make_fountain_site.sh).
//
// - Overlay: projected through the model document's camera, every sparse
//   point lands on the keypoints that observe it (mean <= 2 px).
// - Exports: the COLMAP tar reads back with the same poses; the geo CSV is
//   the model's geo-registration and compares with the ground truth; the
//   PLYs hold the clouds in their frames.
// - HTTP: the same bytes through the server, and its errors; the textured
//   mesh the engine made, as the web viewer streams it.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <Eigen/Geometry>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "arscout/db/store.h"
#include "arscout/engine/mesh.h"
#include "arscout/engine/model_io.h"
#include "arscout/engine/service.h"
#include "arscout/http/client.h"
#include "arscout/ingest/auth.h"
#include "arscout/ingest/server.h"
#include "arscout/util/error.h"
#include "arscout/viewer/exports.h"
#include "arscout/viewer/overlay.h"
#include "arscout/viewer/routes.h"
#include "model_eval.h"
#include "overlay_meshes.h"
#include "test_stores.h"
#include "tool_process.h"

namespace arscout::viewer {
namespace {

namespace fs = std::filesystem;

std::string read_file(const fs::path& path) {
  std::ostringstream bytes;
  bytes << std::ifstream(path, std::ios::binary).rdbuf();
  return bytes.str();
}

// "alice.0005.jpg" -> "0005.jpg", the ground truth's names: the capture id
// less the scout's space.
std::string photo_name(const std::string& capture) {
  return capture.substr(capture.find('.') + 1);
}

class FountainSite : public ::testing::Test {
 protected:
  void SetUp() override {
    ARSCOUT_SHARED_DATA_OR_SKIP(scene_, "strecha/fountain-P11");
    const fs::path site(ARSCOUT_VIEWER_SITE);
    if (!fs::exists(site / "ready")) {
      const std::string why = "no fountain site at " + site.string() +
                              " (the viewer.fountain_site fixture failed?)";
      if (testing::in_ci()) FAIL() << why;
      GTEST_SKIP() << why;
    }
    // A copy: tests must not change the fixture the others read.
    dir_ = testing::make_temp_dir("viewer-site");
    for (const char* name : {"arscout.db", "arscout.db-wal", "arscout.db-shm"})
      if (fs::exists(site / name)) fs::copy_file(site / name, dir_ / name);
    store_ = db::Store::open("sqlite:" + (dir_ / "arscout.db").string());
    const auto sites = store_->list_children("/sites");
    ASSERT_EQ(sites.size(), 1u);
    site_ = sites[0].path.substr(7);
    model_ = load_site_model(*store_, site_);
  }

  // The API server with the viewer's routes on the copy, on a free port.
  std::unique_ptr<ingest::Server> serve() {
    ingest::ServerOptions options;
    options.port = 0;
    options.routes = viewer_routes(*store_);
    auto server = std::make_unique<ingest::Server>(*store_, options);
    server->start();
    return server;
  }
  // A client of `server` with a new planner token named `name`.
  http::ClientOptions planner_client(const ingest::Server& server,
                                     const std::string& name) {
    http::ClientOptions options;
    options.server = "http://127.0.0.1:" + std::to_string(server.port());
    options.token = ingest::create_token(*store_, ingest::Role::kPlanner, name);
    return options;
  }

  std::string scene_;
  fs::path dir_;
  std::unique_ptr<db::Store> store_;
  std::string site_;
  SiteModel model_;
};

TEST_F(FountainSite, OverlayProjectsSparsePointsOntoTheirKeypoints) {
  const engine::Model full = load_full_model(*store_, model_);
  std::map<int64_t, Eigen::Vector3d> points;
  for (const engine::ModelPoint& p : full.points)
    points[p.id] = Eigen::Vector3d(p.xyz[0], p.xyz[1], p.xyz[2]);
  ASSERT_EQ(full.images.size(), 10u);
  double worst = 0;
  for (const engine::ModelImage& image : full.images) {
    // The camera the overlay endpoint draws with: the model document's.
    const auto camera = image_camera(model_, image.id);
    ASSERT_TRUE(camera) << image.id;
    double sum = 0;
    int n = 0;
    for (size_t k = 0; k < image.keypoints.size(); ++k) {
      if (image.point_ids[k] < 0) continue;
      const auto pixel = project(*camera, points.at(image.point_ids[k]));
      ASSERT_TRUE(pixel);
      sum += (*pixel -
              Eigen::Vector2d(image.keypoints[k][0], image.keypoints[k][1]))
                 .norm();
      ++n;
    }
    ASSERT_GT(n, 200) << image.id;
    const double mean = sum / n;
    worst = std::max(worst, mean);
    EXPECT_LE(mean, 2.0) << image.id;
  }
  std::cout << "overlay: sparse points vs their keypoints, worst image mean "
            << worst << " px" << std::endl;
}

TEST_F(FountainSite, OverlayDrawsTheModelOverThePhoto) {
  const std::string jpeg = overlay_jpeg(*store_, "alice.0005.jpg", {});
  const cv::Mat overlay =
      cv::imdecode(cv::Mat(1, static_cast<int>(jpeg.size()), CV_8U,
                           const_cast<char*>(jpeg.data())),
                   cv::IMREAD_COLOR);
  ASSERT_EQ(overlay.size(), cv::Size(1280, 853));
  cv::Mat photo = cv::imread(scene_ + "/images/0005.jpg", cv::IMREAD_COLOR);
  cv::resize(photo, photo, overlay.size(), 0, 0, cv::INTER_AREA);
  cv::Mat difference;
  cv::absdiff(photo, overlay, difference);
  cv::cvtColor(difference, difference, cv::COLOR_BGR2GRAY);
  const double drawn = cv::countNonZero(difference > 40) /
                       static_cast<double>(difference.total());
  std::cout << "overlay of 0005.jpg: " << drawn * 100
            << " % of the pixels drawn" << std::endl;
  EXPECT_GT(drawn, 0.3);
  EXPECT_THROW(overlay_jpeg(*store_, "alice.nope.jpg", {}), util::Error);
}

// The scout's overlay of the textured surface: drawn through the photo's
// pose from the mesh tiles it sees, it matches the photo (ZNCC of the grey
// levels over the pixels the surface covers).
TEST_F(FountainSite, OverlayDrawsTheTexturedSurfaceOverThePhoto) {
  const std::string capture = "alice.0005.jpg";
  OverlayOptions options;
  options.draw = OverlayDraw::kMesh;
  options.opacity = 1;
  const std::string jpeg = overlay_jpeg(*store_, capture, options);
  const cv::Mat overlay =
      cv::imdecode(cv::Mat(1, static_cast<int>(jpeg.size()), CV_8U,
                           const_cast<char*>(jpeg.data())),
                   cv::IMREAD_GRAYSCALE);
  ASSERT_EQ(overlay.size(), cv::Size(1280, 853));
  // Where the surface is: the same drawing over a white picture, compared
  // with one over black (a texel may be black or white, not both).
  const auto camera = image_camera(model_, capture);
  ASSERT_TRUE(camera);
  const std::vector<engine::TexturedMesh> meshes = meshes_seen_by(
      *store_, model_, *camera,
      camera->intrinsics.fx * 1280.0 /
          std::max(camera->intrinsics.width, camera->intrinsics.height));
  ASSERT_FALSE(meshes.empty());
  const cv::Size photo_size(camera->intrinsics.width,
                            camera->intrinsics.height);
  const cv::Mat on_black =
      draw_mesh_overlay(cv::Mat(photo_size, CV_8UC3, cv::Scalar::all(0)),
                        *camera, meshes, options);
  const cv::Mat on_white =
      draw_mesh_overlay(cv::Mat(photo_size, CV_8UC3, cv::Scalar::all(255)),
                        *camera, meshes, options);
  cv::Mat same;
  cv::compare(on_black, on_white, same, cv::CMP_EQ);
  cv::cvtColor(same, same, cv::COLOR_BGR2GRAY);
  const cv::Mat covered = same == 255;
  ASSERT_EQ(covered.size(), overlay.size());
  cv::Mat photo = cv::imread(scene_ + "/images/0005.jpg", cv::IMREAD_GRAYSCALE);
  cv::resize(photo, photo, overlay.size(), 0, 0, cv::INTER_AREA);
  cv::Scalar mean_a, sd_a, mean_b, sd_b;
  cv::meanStdDev(overlay, mean_a, sd_a, covered);
  cv::meanStdDev(photo, mean_b, sd_b, covered);
  cv::Mat a, b;
  overlay.convertTo(a, CV_64F, 1, -mean_a[0]);
  photo.convertTo(b, CV_64F, 1, -mean_b[0]);
  const double n = cv::countNonZero(covered);
  const double zncc = cv::mean(a.mul(b), covered)[0] / (sd_a[0] * sd_b[0]);
  std::cout << "surface overlay of 0005.jpg: " << meshes.size()
            << " tiles, covers " << n / overlay.total() * 100
            << " % of the picture, ZNCC " << zncc << std::endl;
  EXPECT_GT(n / overlay.total(), 0.3);
  EXPECT_GT(zncc, 0.6);
}

TEST_F(FountainSite, ColmapExportReadsBackWithTheSamePoses) {
  const ExportFile file = export_site(*store_, site_, "colmap");
  EXPECT_EQ(file.content_type, "application/x-tar");
  std::ofstream(dir_ / "model.tar", std::ios::binary) << file.bytes;
  ASSERT_EQ(std::system(("tar -xf '" + (dir_ / "model.tar").string() +
                         "' -C '" + dir_.string() + "'")
                            .c_str()),
            0);
  const engine::Model back = engine::read_colmap_text((dir_ / site_).string());
  const Json& images = model_.attrs.at("images");
  ASSERT_EQ(back.images.size(), images.size());
  std::map<std::string, eval::Pose> estimated;
  for (size_t i = 0; i < images.size(); ++i) {
    const engine::ModelImage& b = back.images[i];
    EXPECT_EQ(b.id, images[i].at("id"));
    const auto q = images[i].at("qvec").get<std::array<double, 4>>();
    const auto t = images[i].at("tvec").get<std::array<double, 3>>();
    for (int k = 0; k < 4; ++k) EXPECT_NEAR(b.qvec[k], q[k], 1e-12);
    for (int k = 0; k < 3; ++k)
      EXPECT_NEAR(b.tvec[k], t[k], 1e-9 * (1 + std::abs(t[k])));
    eval::Pose pose;
    pose.name = photo_name(b.id);
    pose.R = Eigen::Quaterniond(b.qvec[0], b.qvec[1], b.qvec[2], b.qvec[3])
                 .toRotationMatrix();
    pose.t = Eigen::Vector3d(b.tvec[0], b.tvec[1], b.tvec[2]);
    estimated[pose.name] = pose;
  }
  EXPECT_EQ(static_cast<int64_t>(back.points.size()),
            model_.attrs.at("statistics").at("sparse_points").get<int64_t>());
  // The export is something the evaluation tools can judge: against the
  // Strecha ground truth, as the reconstruction tests do.
  const eval::PoseComparison truth = eval::compare_to_ground_truth(
      estimated, eval::read_strecha_ground_truth(scene_ + "/gt_dense_cameras"));
  std::cout << "COLMAP export vs ground truth: median centre error "
            << truth.median_centre_error * 1000 << " mm, rotation "
            << truth.median_rotation_error_deg << " deg" << std::endl;
  EXPECT_EQ(truth.matched, 10);
  EXPECT_LE(truth.median_centre_error, 0.005);
  EXPECT_LE(truth.median_rotation_error_deg, 0.1);
}

TEST_F(FountainSite, GeoCsvIsTheModelsGeoRegistration) {
  const ExportFile file = export_site(*store_, site_, "geocsv");
  std::ofstream(dir_ / "cameras.csv") << file.bytes;
  const auto rows = eval::read_geo_csv((dir_ / "cameras.csv").string());
  const Json& images = model_.attrs.at("images");
  ASSERT_EQ(rows.size(), images.size());
  std::map<std::string, eval::GeoRow> renamed;
  for (const Json& image : images) {
    const std::string id = image.at("id");
    ASSERT_TRUE(rows.count(id)) << id;
    const eval::GeoRow& row = rows.at(id);
    const Json& g = image.at("geodetic");
    EXPECT_NEAR(row.lat, g.at("lat").get<double>(), 1e-9);
    EXPECT_NEAR(row.lon, g.at("lon").get<double>(), 1e-9);
    EXPECT_NEAR(row.alt, g.at("alt").get<double>(), 1e-3);
    renamed[photo_name(id)] = row;
  }
  int matched = 0;
  const double metres = eval::median_geo_distance(
      renamed, eval::read_geo_csv(scene_ + "/gps_truth.csv"), &matched);
  std::cout << "geo CSV vs gps_truth.csv: median " << metres << " m over "
            << matched << " cameras" << std::endl;
  EXPECT_EQ(matched, 10);
  // The frame comes from 10 fixes with 1.5 m of noise per axis; the
  // engine's own 1 m target (11 photos) is the reconstruction tests'. Here
  // the point is that the file is comparable with the truth at all: a wrong
  // column, unit or frame would be metres to kilometres off.
  EXPECT_LE(metres, 1.5);
}

TEST_F(FountainSite, PlyExportsHoldTheCloudsInTheirFrames) {
  const ExportFile enu = export_site(*store_, site_, "ply");
  const ExportFile sparse = export_site(*store_, site_, "ply", Cloud::kSparse);
  EXPECT_EQ(sparse.bytes, store_->get_blob(model_.sparse_blob));
  // The dense PLY joins the stored tiles, point for point.
  const auto cloud = engine::decode_ply(enu.bytes);
  const auto tiles = engine::load_dense_cloud(*store_, model_.dense_blobs);
  ASSERT_EQ(cloud.size(), tiles.size());
  ASSERT_GT(cloud.size(), 0u);
  for (std::size_t i = 0; i < cloud.size(); ++i)
    ASSERT_TRUE(cloud[i].x == tiles[i].x && cloud[i].y == tiles[i].y &&
                cloud[i].z == tiles[i].z && cloud[i].r == tiles[i].r &&
                cloud[i].g == tiles[i].g && cloud[i].b == tiles[i].b)
        << "point " << i;

  const ExportFile ecef = export_site(*store_, site_, "ecef-ply");
  const size_t end = ecef.bytes.find("end_header\n");
  ASSERT_NE(end, std::string::npos);
  EXPECT_NE(ecef.bytes.find("element vertex " + std::to_string(cloud.size())),
            std::string::npos);
  ASSERT_EQ(ecef.bytes.size() - end - 11, cloud.size() * 27);
  // Each point is the ENU point moved into ECEF: distances are kept, and
  // the cloud sits within 100 m of the ENU origin on the ellipsoid.
  const Json& o = model_.attrs.at("enu_origin");
  const engine::EnuFrame frame({o.at("lat"), o.at("lon"), o.at("alt")});
  const auto origin = frame.to_ecef({0, 0, 0});
  auto ecef_point = [&](size_t i) {
    double v[3];
    std::memcpy(v, ecef.bytes.data() + end + 11 + 27 * i, sizeof v);
    return Eigen::Vector3d(v[0], v[1], v[2]);
  };
  for (size_t i = 0; i < cloud.size(); i += cloud.size() / 50) {
    const Eigen::Vector3d p = ecef_point(i);
    const Eigen::Vector3d enu_p(cloud[i].x, cloud[i].y, cloud[i].z);
    EXPECT_NEAR((p - Eigen::Vector3d(origin[0], origin[1], origin[2])).norm(),
                enu_p.norm(), 1e-4);
  }
}

TEST_F(FountainSite, EndpointsServeTheSameBytesAndClearErrors) {
  const auto server = serve();
  http::ClientOptions client_options = planner_client(*server, "pat");
  http::Client client(client_options);

  const auto tar = client.get("/v1/sites/" + site_ + "/export?format=colmap");
  ASSERT_EQ(tar.status, 200) << tar.body;
  EXPECT_EQ(tar.body, export_site(*store_, site_, "colmap").bytes);
  EXPECT_NE(tar.headers.at("content-disposition").find("colmap.tar"),
            std::string::npos);
  const auto overlay = client.get("/v1/captures/alice.0003.jpg/overlay.jpg");
  ASSERT_EQ(overlay.status, 200);
  EXPECT_EQ(overlay.headers.at("content-type"), "image/jpeg");
  const auto thumbnail =
      client.get("/v1/captures/alice.0003.jpg/thumbnail.jpg?size=200");
  ASSERT_EQ(thumbnail.status, 200);
  const cv::Mat small =
      cv::imdecode(cv::Mat(1, static_cast<int>(thumbnail.body.size()), CV_8U,
                           const_cast<char*>(thumbnail.body.data())),
                   cv::IMREAD_COLOR);
  EXPECT_EQ(small.size(), cv::Size(200, 133));

  const auto captures = client.get("/v1/sites/" + site_ + "/captures");
  ASSERT_EQ(captures.status, 200);
  const Json listed = captures.json().at("captures");
  ASSERT_EQ(listed.size(), 10u);
  for (const Json& doc : listed) EXPECT_EQ(doc.at("attrs").at("site"), site_);
  EXPECT_TRUE(
      client.get("/v1/sites/nowhere/captures").json().at("captures").empty());

  // The cameras on a map: each at the model document's geodetic position.
  const auto cameras = client.get("/v1/sites/" + site_ + "/cameras.geojson");
  ASSERT_EQ(cameras.status, 200) << cameras.body;
  EXPECT_EQ(cameras.headers.at("content-type"), "application/geo+json");
  const Json features = cameras.json().at("features");
  ASSERT_EQ(features.size(), 10u);
  for (const Json& f : features) {
    const Json& image = *std::find_if(
        model_.attrs.at("images").begin(), model_.attrs.at("images").end(),
        [&](const Json& i) { return i.at("id") == f.at("id"); });
    EXPECT_EQ(f["geometry"]["coordinates"][0], image["geodetic"]["lon"]);
    EXPECT_EQ(f["geometry"]["coordinates"][1], image["geodetic"]["lat"]);
  }
  // 3D Tiles: a zip of SITE/tileset.json and the tiles, the same bytes.
  const auto tiles =
      client.get("/v1/sites/" + site_ + "/export?format=3dtiles");
  ASSERT_EQ(tiles.status, 200);
  EXPECT_EQ(tiles.headers.at("content-type"), "application/zip");
  EXPECT_EQ(tiles.body, export_site(*store_, site_, "3dtiles").bytes);
  EXPECT_NE(tiles.body.find(site_ + "/tileset.json"), std::string::npos);
  // "obj" was this test's unknown format until the mesh exports made it one.
  EXPECT_EQ(client.get("/v1/sites/" + site_ + "/export?format=stl").status,
            400);
  EXPECT_EQ(client.get("/v1/sites/nowhere/export?format=ply").status, 404);
  EXPECT_EQ(client.get("/v1/captures/nobody/overlay.jpg").status, 404);
  EXPECT_EQ(
      client.get("/v1/captures/alice.0003.jpg/overlay.jpg?draw=wire").status,
      400);
  EXPECT_EQ(
      client.get("/v1/captures/alice.0003.jpg/overlay.jpg?opacity=101").status,
      400);
  const auto surface =
      client.get("/v1/captures/alice.0003.jpg/overlay.jpg?draw=mesh");
  ASSERT_EQ(surface.status, 200);
  EXPECT_EQ(surface.headers.at("content-type"), "image/jpeg");
  EXPECT_EQ(
      client.get("/v1/captures/alice.0003.jpg/thumbnail.jpg?size=0").status,
      400);
  EXPECT_EQ(client.request("DELETE", "/v1/captures/alice.0003.jpg/overlay.jpg")
                .status,
            405);
  client_options.token = "";
  EXPECT_EQ(http::Client(client_options)
                .get("/v1/sites/" + site_ + "/export?format=ply")
                .status,
            401);
}

TEST_F(FountainSite, ExportCommandWritesTheSameFile) {
  store_.reset();  // the command opens the store itself
  const std::string out = (dir_ / "cameras.csv").string();
  const std::string command =
      std::string(ARSCOUT_CLI) +
      " export --db sqlite:" + (dir_ / "arscout.db").string() + " --site " +
      site_ + " --format geocsv -o " + out;
  ASSERT_EQ(std::system(command.c_str()), 0);
  store_ = db::Store::open("sqlite:" + (dir_ / "arscout.db").string());
  EXPECT_EQ(read_file(out), export_site(*store_, site_, "geocsv").bytes);
  // The cameras as GeoJSON: the bytes GET .../cameras.geojson serves.
  const std::string geojson = (dir_ / "cameras.geojson").string();
  store_.reset();
  ASSERT_EQ(std::system((std::string(ARSCOUT_CLI) + " export --db sqlite:" +
                         (dir_ / "arscout.db").string() + " --site " + site_ +
                         " --format geojson -o " + geojson)
                            .c_str()),
            0);
  store_ = db::Store::open("sqlite:" + (dir_ / "arscout.db").string());
  const auto server = serve();
  http::Client client(planner_client(*server, "map"));
  const auto served = client.get("/v1/sites/" + site_ + "/cameras.geojson");
  ASSERT_EQ(served.status, 200);
  EXPECT_EQ(read_file(geojson), served.body);
  server->stop();
  const std::string bad = std::string(ARSCOUT_CLI) + " export --db sqlite:" +
                          (dir_ / "arscout.db").string() + " --site " + site_ +
                          " --format stl -o " + out + " 2>/dev/null";
  EXPECT_NE(std::system(bad.c_str()), 0);
}

// LAS on the real site: the CLI and the HTTP route give the export's bytes,
// and EGM96 heights sit below the ellipsoidal ones by the geoid undulation
// PROJ's own cs2cs gives at the site (docs/frames.md).
TEST_F(FountainSite, LasExportsAgreeAndCarryGeoidHeights) {
  ExportOptions egm96;
  egm96.heights = "egm96";
  const ExportFile las = export_site(*store_, site_, "las", egm96);
  const ExportFile ellipsoidal =
      export_site(*store_, site_, "las", ExportOptions{});
  ASSERT_EQ(las.bytes.substr(0, 4), "LASF");
  std::uint64_t count = 0;
  std::uint32_t offset = 0;
  std::memcpy(&count, las.bytes.data() + 247, sizeof count);
  std::memcpy(&offset, las.bytes.data() + 96, sizeof offset);
  std::uint16_t record = 0;
  std::memcpy(&record, las.bytes.data() + 105, sizeof record);
  ASSERT_GT(count, 1000u);
  // The fused cloud's records carry support, normal and score (14 extra
  // bytes).
  EXPECT_EQ(record, 36 + 14);
  ASSERT_EQ(las.bytes.size(), offset + record * count);
  double z_scale = 0, z_offset[2] = {0, 0};
  std::memcpy(&z_scale, las.bytes.data() + 147, sizeof z_scale);
  std::memcpy(&z_offset[0], las.bytes.data() + 171, sizeof(double));
  std::memcpy(&z_offset[1], ellipsoidal.bytes.data() + 171, sizeof(double));
  const std::uint32_t ellipsoidal_offset = [&] {
    std::uint32_t o = 0;
    std::memcpy(&o, ellipsoidal.bytes.data() + 96, sizeof o);
    return o;
  }();
  const auto z_at = [&](const std::string& bytes, std::uint32_t at, size_t i,
                        double base) {
    std::int32_t z = 0;
    std::memcpy(&z, bytes.data() + at + record * i + 8, sizeof z);
    return z * z_scale + base;
  };
  const Json& o = model_.attrs.at("enu_origin");
  const std::string cs2cs = "echo '" +
                            std::to_string(o.at("lat").get<double>()) + " " +
                            std::to_string(o.at("lon").get<double>()) +
                            " 0' | cs2cs -f %.4f EPSG:4979 EPSG:4326+5773";
  const std::string answer = testing::command_output(cs2cs);
  double lat = 0, lon = 0, height = 0;
  ASSERT_EQ(std::sscanf(answer.c_str(), "%lf %lf %lf", &lat, &lon, &height), 3)
      << "cs2cs (proj-bin) said '" << answer << "'";
  const double undulation = -height;
  for (size_t i = 0; i < count; i += count / 100)
    EXPECT_NEAR(z_at(ellipsoidal.bytes, ellipsoidal_offset, i, z_offset[1]) -
                    z_at(las.bytes, offset, i, z_offset[0]),
                undulation, 0.05)
        << i;
  std::cout << "fountain-P11: EGM96 undulation " << undulation
            << " m (cs2cs); LAS of " << count << " points" << std::endl;

  const auto server = serve();
  http::Client client(planner_client(*server, "gis"));
  const auto got = client.get("/v1/sites/" + site_ +
                              "/export?format=las&crs=utm&heights=egm96");
  ASSERT_EQ(got.status, 200) << got.body;
  EXPECT_EQ(got.body, las.bytes);
  // The site is in Lausanne: the Swiss grid fits it, the British does not.
  const auto swiss =
      client.get("/v1/sites/" + site_ + "/export?format=las&crs=EPSG:2056");
  ASSERT_EQ(swiss.status, 200);
  EXPECT_NE(swiss.body.find("CH1903+ / LV95"), std::string::npos);
  const auto british =
      client.get("/v1/sites/" + site_ + "/export?format=las&crs=EPSG:27700");
  EXPECT_EQ(british.status, 422);
  EXPECT_NE(british.body.find("the site is at"), std::string::npos)
      << british.body;
  server->stop();

  store_.reset();  // the command opens the store itself
  const std::string out = (dir_ / "site.las").string();
  ASSERT_EQ(std::system((std::string(ARSCOUT_CLI) + " export --db sqlite:" +
                         (dir_ / "arscout.db").string() + " --site " + site_ +
                         " --format las --heights egm96 -o " + out)
                            .c_str()),
            0);
  EXPECT_EQ(read_file(out), las.bytes);
}

// The viewer's streamed cloud: the hierarchy of the current version, its
// nodes' bytes, and the errors for a stale version or an unknown node; and
// a picked point's coordinates in the site's UTM zone.
TEST_F(FountainSite, OctreeAndCoordinatesEndpoints) {
  const auto server = serve();
  http::Client client(planner_client(*server, "viewer"));
  const std::string base = "/v1/sites/" + site_;
  const auto hierarchy = client.get(base + "/octree");
  ASSERT_EQ(hierarchy.status, 200) << hierarchy.body;
  const Json tree = hierarchy.json();
  EXPECT_EQ(tree.at("version"), model_.version);
  EXPECT_EQ(tree.at("cloud"), "dense");
  const std::size_t dense =
      load_cloud(*store_, load_site_model(*store_, site_)).size();
  EXPECT_EQ(tree.at("points"), dense);
  std::size_t total = 0;
  for (const Json& node : tree.at("nodes"))
    total += node.at("points").get<std::size_t>();
  EXPECT_EQ(total, dense);
  const std::string version = std::to_string(model_.version);
  const auto root = client.get(base + "/octree/" + version + "/r.bin");
  ASSERT_EQ(root.status, 200);
  EXPECT_EQ(root.body.size(),
            16 * tree.at("nodes").at(0).at("points").get<std::size_t>());
  EXPECT_NE(root.headers.at("cache-control").find("immutable"),
            std::string::npos);
  EXPECT_EQ(client.get(base + "/octree/" + version + "/r9.bin").status, 404);
  EXPECT_EQ(client.get(base + "/octree/999999/r.bin").status, 410);
  const auto sparse = client.get(base + "/octree?cloud=sparse");
  ASSERT_EQ(sparse.status, 200);
  EXPECT_EQ(sparse.json().at("cloud"), "sparse");
  EXPECT_EQ(client.get(base + "/octree?cloud=mesh").status, 400);
  EXPECT_EQ(client.get("/v1/sites/nowhere/octree").status, 404);

  // The ENU origin is the model's origin on WGS84; in UTM zone 32 north.
  const auto origin = client.get(base + "/coordinates?x=0&y=0&z=0");
  ASSERT_EQ(origin.status, 200) << origin.body;
  const Json& o = model_.attrs.at("enu_origin");
  EXPECT_NEAR(origin.json().at("wgs84").at("lat"), o.at("lat"), 1e-9);
  EXPECT_NEAR(origin.json().at("wgs84").at("lon"), o.at("lon"), 1e-9);
  EXPECT_EQ(origin.json().at("crs"), "EPSG:32632");
  const auto moved =
      client.get(base + "/coordinates?x=10&y=20&z=0&heights=egm96");
  ASSERT_EQ(moved.status, 200) << moved.body;
  EXPECT_EQ(moved.json().at("crs"), "EPSG:32632+5773");
  // UTM's scale near the central meridian is close to 1 (0.9996 at it).
  const Json a = origin.json().at("coordinates"),
             b = moved.json().at("coordinates");
  const double metres = std::hypot(b[0].get<double>() - a[0].get<double>(),
                                   b[1].get<double>() - a[1].get<double>());
  EXPECT_NEAR(metres, std::hypot(10.0, 20.0), 0.05);
  EXPECT_EQ(client.get(base + "/coordinates?x=1&y=2").status, 400);
  EXPECT_EQ(client.get(base + "/coordinates?x=1&y=2&z=nan").status, 400);
  EXPECT_EQ(client.get(base + "/coordinates?x=0&y=0&z=0&crs=EPSG:27700").status,
            422);
  server->stop();
}

// The textured mesh the engine made (the fixture runs it with --mesh), as
// the web viewer streams it: every tile with levels listed with its
// levels and the box of their vertices, each level's bytes the stored GLB,
// and the errors for an unknown tile and a level out of range.
TEST_F(FountainSite, MeshEndpointsServeTheEnginesLevels) {
  db::Document document;
  document.attrs = model_.attrs;
  std::vector<engine::MeshTileEntry> tiles;
  for (engine::MeshTileEntry& tile : engine::mesh_tiles_of(document))
    if (!tile.levels.empty()) tiles.push_back(std::move(tile));
  ASSERT_FALSE(tiles.empty()) << "the fixture's model has no mesh";
  const auto server = serve();
  http::Client client(planner_client(*server, "mesh"));
  const std::string base = "/v1/sites/" + site_ + "/mesh";
  const auto got = client.get(base);
  ASSERT_EQ(got.status, 200) << got.body;
  const Json listing = got.json();
  EXPECT_EQ(listing.at("version"), model_.version);
  ASSERT_EQ(listing.at("tiles").size(), tiles.size());
  for (std::size_t t = 0; t < tiles.size(); ++t) {
    const Json& tile = listing["tiles"][t];
    EXPECT_EQ(tile.at("tile"), tiles[t].tile);
    ASSERT_EQ(tile.at("levels").size(), tiles[t].levels.size());
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
    for (std::size_t l = 0; l < tiles[t].levels.size(); ++l) {
      const Json& level = tile["levels"][l];
      EXPECT_EQ(level.at("triangles"), tiles[t].levels[l].triangles);
      const auto glb = client.get(level.at("url").get<std::string>());
      ASSERT_EQ(glb.status, 200) << glb.body;
      EXPECT_EQ(glb.headers.at("content-type"), "model/gltf-binary");
      EXPECT_EQ(glb.body, store_->get_blob(tiles[t].levels[l].blob));
      const engine::TexturedMesh mesh = engine::decode_glb(glb.body);
      EXPECT_EQ(mesh.triangles(), tiles[t].levels[l].triangles);
      EXPECT_FALSE(mesh.atlas.empty()) << "level " << l << " is not textured";
      for (const Eigen::Vector3f& p : mesh.positions) {
        lo = lo.cwiseMin(p.cast<double>());
        hi = hi.cwiseMax(p.cast<double>());
      }
    }
    for (int a = 0; a < 3; ++a) {
      EXPECT_NEAR(tile["lo"][a].get<double>(), lo[a], 1e-5);
      EXPECT_NEAR(tile["hi"][a].get<double>(), hi[a], 1e-5);
    }
  }
  const std::string first = base + "/" + tiles[0].tile + "/";
  EXPECT_EQ(client.get(base + "/nowhere/0").status, 404);
  EXPECT_EQ(client.get(first + std::to_string(tiles[0].levels.size())).status,
            404);
  EXPECT_EQ(client.get(first + "0?blob=" + std::string(64, '0')).status, 410);
  server->stop();
}

// Coverage on the fountain: photographed from one arc in front of it, so
// its facade has cells and the suggestions ask for more of it.
TEST_F(FountainSite, CoverageIsGeoJsonWithClearErrors) {
  const auto server = serve();
  http::Client client(planner_client(*server, "coverage"));
  const std::string base = "/v1/sites/" + site_ + "/coverage";
  const auto got = client.get(base);
  ASSERT_EQ(got.status, 200) << got.body;
  EXPECT_EQ(got.headers.at("content-type"), "application/geo+json");
  const Json body = got.json();
  EXPECT_EQ(body.at("type"), "FeatureCollection");
  EXPECT_EQ(body.at("model_version"), model_.version);
  const Json& o = model_.attrs.at("enu_origin");
  int cells = 0, suggestions = 0;
  for (const Json& f : body.at("features")) {
    const std::string kind = f.at("properties").at("feature");
    if (kind == "cell") {
      ++cells;
      EXPECT_GE(f["properties"]["views"].get<int>(), 2);
      EXPECT_GE(f["properties"]["directions"].get<int>(), 1);
      const Json& corner = f["geometry"]["coordinates"][0][0];
      // Within a few hundred metres of the site's origin.
      EXPECT_NEAR(corner[0].get<double>(), o.at("lon").get<double>(), 0.005);
      EXPECT_NEAR(corner[1].get<double>(), o.at("lat").get<double>(), 0.005);
    } else if (kind == "suggestion") {
      EXPECT_EQ(f["properties"]["rank"], ++suggestions);
      EXPECT_FALSE(f["properties"]["reason"].get<std::string>().empty());
      const double heading = f["properties"]["heading_deg"];
      EXPECT_TRUE(heading >= 0 && heading <= 360) << heading;
    } else {
      EXPECT_EQ(kind, "unseen_facade");
    }
  }
  EXPECT_GT(cells, 3);
  EXPECT_GT(suggestions, 0);
  EXPECT_LE(suggestions, 5);
  const auto one = client.get(
      base + "?max=1&near=" + std::to_string(o.at("lat").get<double>()) + "," +
      std::to_string(o.at("lon").get<double>()));
  ASSERT_EQ(one.status, 200) << one.body;
  int ranked = 0;
  const Json ranked_body = one.json();
  for (const Json& f : ranked_body.at("features"))
    ranked += f["properties"]["feature"] == "suggestion";
  EXPECT_EQ(ranked, 1) << one.body;
  for (const char* bad : {"?near=91,0", "?near=55.7", "?near=a,b",
                          "?near=1,2,3", "?max=21", "?max=-1", "?max=x"}) {
    const auto r = client.get(base + bad);
    EXPECT_EQ(r.status, 400) << bad;
    EXPECT_EQ(r.json().at("error"), "bad_request") << bad;
  }
  const auto missing = client.get("/v1/sites/nowhere/coverage");
  EXPECT_EQ(missing.status, 404);
  EXPECT_NE(missing.json().at("message").get<std::string>().find("nowhere"),
            std::string::npos);
  EXPECT_EQ(client.request("POST", base, "{}").status, 405);
  server->stop();
}

}  // namespace
}  // namespace arscout::viewer
