// The engine worker end to end on a real store (SQLite and PostgreSQL): two
// scouts upload fountain-P11 (Lausanne) and opensfm/lund (Lund) at the same
// time, as capture documents the API would write; the worker places them
// in two sites, reconstructs both and writes models and statuses back. A
// second worker on the same store then finds nothing left to do.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <stdexcept>
#include <thread>
#include <tuple>

#include <Eigen/Geometry>
#include "arscout/db/store.h"
#include "arscout/engine/camera.h"
#include "arscout/engine/mesh.h"
#include "arscout/engine/ply.h"
#include "arscout/engine/service.h"
#include "arscout/metadata/gps.h"

#include "camera_document.h"
#include "model_eval.h"
#include "test_stores.h"

namespace arscout {
namespace {

namespace fs = std::filesystem;
using db::Json;

std::string read_file(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream bytes;
  bytes << in.rdbuf();
  return bytes.str();
}

// Stores one photo as the API would: the image blob, then the capture.
void upload(db::Store& store, const std::string& scout, const fs::path& photo,
            const metadata::GpsFix& fix, const std::string& camera) {
  const std::string sha = store.put_blob(read_file(photo));
  Json attrs = {{"scout", scout},
                {"filename", photo.filename().string()},
                {"gps", metadata::to_json(fix)},
                {"status", "stored"},
                {"status_reason", ""}};
  if (!camera.empty()) attrs["camera"] = camera;
  db::WriteOp op = db::WriteOp::put(
      "/captures/" + scout + "-" + photo.stem().string(), "capture", attrs, 0);
  op.blobs = db::BlobRefs{{"image", sha}};
  store.batch({op});
}

std::vector<fs::path> photos(const std::string& dir) {
  std::vector<fs::path> out;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ".jpg") out.push_back(e.path());
  std::sort(out.begin(), out.end());
  return out;
}

// The fountain model's cameras against the scene's ground truth, with the
// reconstruction core's targets (tests/engine/acceptance): median centre
// error <= 5 mm and rotation <= 0.1 degrees after a similarity alignment,
// geo-registration within 1 m of the true positions.
void expect_fountain_accuracy(const Json& model, const std::string& scene) {
  std::map<std::string, eval::Pose> estimated;
  std::map<std::string, eval::GeoRow> geo;
  for (const Json& image : model.at("images")) {
    const std::string name =
        image.at("id").get<std::string>().substr(6) + ".jpg";  // "alice-"
    const auto q = image.at("qvec").get<std::array<double, 4>>();
    eval::Pose pose;
    pose.name = name;
    pose.R = Eigen::Quaterniond(q[0], q[1], q[2], q[3]).toRotationMatrix();
    const auto t = image.at("tvec").get<std::array<double, 3>>();
    pose.t = Eigen::Vector3d(t[0], t[1], t[2]);
    estimated[name] = pose;
    const Json& g = image.at("geodetic");
    geo[name] = eval::GeoRow{g.at("lat"), g.at("lon"), g.at("alt")};
  }
  const eval::PoseComparison poses = eval::compare_to_ground_truth(
      estimated, eval::read_strecha_ground_truth(scene + "/gt_dense_cameras"));
  int geo_matched = 0;
  const double geo_m = eval::median_geo_distance(
      geo, eval::read_geo_csv(scene + "/gps_truth.csv"), &geo_matched);
  std::cout << "fountain against ground truth: median centre error "
            << poses.median_centre_error * 1000 << " mm, rotation "
            << poses.median_rotation_error_deg << " deg, geo " << geo_m << " m"
            << std::endl;
  EXPECT_EQ(poses.matched, 11);
  EXPECT_LE(poses.median_centre_error, 0.005);
  EXPECT_LE(poses.median_rotation_error_deg, 0.1);
  EXPECT_EQ(geo_matched, 11);
  EXPECT_LE(geo_m, 1.0);
}

class EngineWorkerOn : public ::testing::TestWithParam<std::string> {};

TEST_P(EngineWorkerOn, TwoScoutsTwoSitesModelsWrittenBack) {
  std::string fountain, lund, url;
  ARSCOUT_SHARED_DATA_OR_SKIP(fountain, "strecha/fountain-P11");
  ARSCOUT_SHARED_DATA_OR_SKIP(lund, "opensfm/lund");
  ARSCOUT_FRESH_STORE_OR_SKIP(url, GetParam());
  auto store = db::Store::open(url);

  const engine::CameraIntrinsics K =
      engine::read_k_matrix(fountain + "/images/K.txt", 3072, 2048);
  testing::put_calibrated_camera(*store, "fountain", K,
                                 Json::array({0, 0, 0, 0, 0}));

  engine::WorkerOptions options;
  options.progress = [](const std::string& line) {
    std::cout << "  [engine] " << line << std::endl;
  };
  engine::EngineWorker worker(*store, options);
  worker.start();

  const auto fixes = metadata::read_gps_csv(fountain + "/gps.csv");
  std::thread alice([&] {
    for (const fs::path& p : photos(fountain + "/images"))
      upload(*store, "alice", p, fixes.at(p.filename().string()), "fountain");
  });
  std::thread bob([&] {
    for (const fs::path& p : photos(lund + "/images")) {
      const auto exif = metadata::read_exif_file(p.string());
      ASSERT_TRUE(exif.gps) << p;
      upload(*store, "bob", p, *exif.gps, "");
    }
  });
  alice.join();
  bob.join();
  ASSERT_TRUE(worker.wait_idle(std::chrono::minutes(12)));
  const engine::WorkerStats stats = worker.stats();
  EXPECT_EQ(stats.captures_placed, 11 + 29);
  EXPECT_EQ(stats.failures, 0);
  // The photos queued behind an increment were prepared ahead
  // (capture_preparer.h), each used at most once.
  EXPECT_GT(stats.photos_prepared_used, 0);
  EXPECT_LE(stats.photos_prepared_used, stats.photos_prepared);

  const auto sites = store->list_children("/sites");
  ASSERT_EQ(sites.size(), 2u);
  for (const db::Document& site : sites) {
    const std::string id = site.path.substr(7);
    const auto model = store->get(site.path + "/model");
    ASSERT_TRUE(model) << id;
    const bool is_fountain =
        site.attrs.at("captures")[0].get<std::string>().rfind("alice", 0) == 0;
    const int expected = is_fountain ? 11 : 29;
    EXPECT_EQ(site.attrs.value("capture_count", 0), expected) << id;
    const Json& statistics = model->attrs.at("statistics");
    std::cout << id << ": model v" << model->version << ", "
              << statistics.dump() << std::endl;
    EXPECT_EQ(site.attrs.value("model_version", 0), model->version);
    EXPECT_TRUE(model->attrs.value("geo_registered", false)) << id;
    if (is_fountain) {
      EXPECT_EQ(statistics.value("registered", 0), 11);
      expect_fountain_accuracy(model->attrs, fountain);
    } else {
      EXPECT_GE(statistics.value("registered", 0), 25);
    }
    ASSERT_TRUE(model->blobs.count("sparse"));
    const auto dense =
        engine::load_dense_cloud(*store, engine::dense_cloud_blobs(*model));
    EXPECT_GT(dense.size(), 50000u) << id;
    // Every capture says where it went and how it fared.
    for (const Json& c : site.attrs.at("captures")) {
      const auto capture = store->get("/captures/" + c.get<std::string>());
      ASSERT_TRUE(capture);
      EXPECT_EQ(capture->attrs.value("site", ""), id);
      if (is_fountain) {
        EXPECT_EQ(capture->attrs.value("status", ""), "registered");
      }
    }
  }
  worker.stop();

  // A restarted worker resumes from its checkpoint and has nothing to redo.
  std::map<std::string, std::int64_t> versions;
  for (const db::Document& site : sites)
    versions[site.path] = store->get(site.path + "/model")->version;
  engine::EngineWorker again(*store, options);
  again.start();
  ASSERT_TRUE(again.wait_idle(std::chrono::minutes(2)));
  again.stop();
  EXPECT_EQ(again.stats().increments, 0);
  for (const auto& [path, version] : versions)
    EXPECT_EQ(store->get(path + "/model")->version, version) << path;
}

INSTANTIATE_TEST_SUITE_P(Backends, EngineWorkerOn,
                         ::testing::Values("sqlite", "postgresql"),
                         [](const auto& info) { return info.param; });

// The main job's stand-in for ../shared/data: `arscout render-site` writes
// photos of the synthetic street with exact GPS and K, and the worker
// reconstructs them into one geo-registered site with a dense cloud.
// The rendered street of `views` photos (`arscout render-site`) in DIR, and
// its camera document in `store`.
std::string render_street(db::Store& store, int views) {
  const std::string dir = testing::make_temp_dir("render_site");
  const std::string command = std::string(ARSCOUT_CLI) + " render-site --out " +
                              dir + " --views " + std::to_string(views) +
                              " > " + dir + "/render.log 2>&1";
  if (std::system(command.c_str()) != 0)
    throw std::runtime_error("failed: " + command);
  const engine::CameraIntrinsics K =
      engine::read_k_matrix(dir + "/images/K.txt", 1024, 768);
  testing::put_calibrated_camera(store, "synthetic", K);
  return dir;
}

// Uploads the street's photos as alice's; returns them.
std::vector<fs::path> upload_street(db::Store& store, const std::string& dir) {
  const auto fixes = metadata::read_gps_csv(dir + "/gps.csv");
  const auto all = photos(dir + "/images");
  for (const fs::path& p : all)
    upload(store, "alice", p, fixes.at(p.filename().string()), "synthetic");
  return all;
}

TEST(EngineWorker, RenderedSyntheticStreetBecomesOneSite) {
  auto store = db::Store::open(testing::fresh_sqlite_url());
  const std::string dir = render_street(*store, 8);
  engine::WorkerOptions options;
  engine::EngineWorker worker(*store, options);
  worker.start();
  const auto all = upload_street(*store, dir);
  ASSERT_EQ(all.size(), 8u);
  ASSERT_TRUE(worker.wait_idle(std::chrono::minutes(5)));
  const auto sites = store->list_children("/sites");
  ASSERT_EQ(sites.size(), 1u);
  const auto model = store->get(sites[0].path + "/model");
  ASSERT_TRUE(model);
  const Json& statistics = model->attrs.at("statistics");
  std::cout << statistics.dump() << std::endl;
  EXPECT_EQ(statistics.value("registered", 0), 8);
  EXPECT_EQ(model->attrs.value("dense_state", ""), "current");
  EXPECT_TRUE(model->attrs.value("geo_registered", false));
  EXPECT_GT(statistics.value("dense_points", 0), 20000);

  // A withdrawn capture (the API sets its status) yields a model version
  // without it, and its depth map goes. A key view, then: eight photos of
  // one facade from a 4 m arc need fewer maps than photos, and a capture
  // the key views cover has none of its own (docs/dense.md).
  const auto maps = store->list_children(sites[0].path + "/depth");
  std::cout << maps.size() << " depth maps for 8 photos" << std::endl;
  ASSERT_GE(maps.size(), 3u);
  const std::string withdrawn =
      maps[1].path.substr(maps[1].path.rfind('/') + 1);
  store->patch("/captures/" + withdrawn, Json{{"status", "withdrawn"}});
  ASSERT_TRUE(worker.wait_idle(std::chrono::minutes(5)));
  const auto after = store->get(sites[0].path + "/model");
  ASSERT_TRUE(after);
  // Two versions: the sparse phase's (7 cameras, the old cloud), then the
  // dense phase's (the cloud without the withdrawn view).
  EXPECT_EQ(after->version, model->version + 2);
  EXPECT_EQ(after->attrs.value("dense_state", ""), "current");
  EXPECT_NE(engine::dense_cloud_blobs(*after),
            engine::dense_cloud_blobs(*model));
  EXPECT_EQ(after->attrs.at("statistics").value("registered", 0), 7);
  for (const Json& image : after->attrs.at("images"))
    EXPECT_NE(image.value("id", ""), withdrawn);
  EXPECT_EQ(after->attrs.at("increment").at("withdrawn"),
            Json::array({withdrawn}));
  EXPECT_FALSE(store->get(sites[0].path + "/depth/" + withdrawn));
  EXPECT_EQ(store->get("/captures/" + withdrawn)->attrs.value("status", ""),
            "withdrawn");
}

// With WorkerOptions::mesh the dense lane publishes a textured surface per
// dense tile beside the cloud (docs/mesh.md): levels of detail as GLB
// blobs, coarser levels with fewer triangles, the finest with an atlas;
// neighbouring tiles' finest levels meet vertex for vertex on their shared
// border (but where a hole's edge lies on it); the levels' blobs outlive a
// collection.
TEST(EngineWorker, TheDenseLanePublishesATexturedSurfacePerTile) {
  auto store = db::Store::open(testing::fresh_sqlite_url());
  const std::string dir = render_street(*store, 8);
  engine::WorkerOptions options;
  options.mesh = true;
  std::mutex lines_mutex;
  std::vector<std::string> lines;
  options.progress = [&](const std::string& line) {
    std::lock_guard lock(lines_mutex);
    lines.push_back(line);
  };
  engine::EngineWorker worker(*store, options);
  worker.start();
  upload_street(*store, dir);
  ASSERT_TRUE(worker.wait_idle(std::chrono::minutes(5)));
  worker.stop();
  const auto sites = store->list_children("/sites");
  ASSERT_EQ(sites.size(), 1u);
  const auto model = store->get(sites[0].path + "/model");
  ASSERT_TRUE(model);
  const std::vector<engine::MeshTileEntry> tiles =
      engine::mesh_tiles_of(*model);
  ASSERT_FALSE(tiles.empty());
  // Each tile's document refers to its levels' blobs: a collection with no
  // grace keeps every one the model names.
  store->collect_garbage(std::chrono::seconds(0));
  for (const engine::MeshTileEntry& tile : tiles) {
    const auto doc = store->get(sites[0].path + "/mesh/" + tile.tile);
    ASSERT_TRUE(doc) << tile.tile;
    EXPECT_EQ(doc->blobs.size(), tile.levels.size());
  }
  std::map<std::string, engine::TexturedMesh> finest;
  std::size_t triangles = 0;
  for (const engine::MeshTileEntry& tile : tiles) {
    if (tile.levels.empty()) continue;
    for (std::size_t l = 1; l < tile.levels.size(); ++l)
      EXPECT_LT(tile.levels[l].triangles, tile.levels[l - 1].triangles);
    finest[tile.tile] =
        engine::decode_glb(store->get_blob(tile.levels.front().blob));
    EXPECT_EQ(finest[tile.tile].triangles(), tile.levels.front().triangles);
    EXPECT_FALSE(finest[tile.tile].atlas.empty()) << tile.tile;
    triangles += tile.levels.front().triangles;
  }
  std::cout << tiles.size() << " mesh tiles, " << triangles << " triangles"
            << std::endl;
  EXPECT_GT(triangles, 20000u);
  {
    std::lock_guard lock(lines_mutex);
    EXPECT_TRUE(std::any_of(lines.begin(), lines.end(), [](const auto& l) {
      return l.find(", mesh ") != std::string::npos;
    }));
  }
  // Neighbouring tiles share a plane (x or y = a multiple of the edge):
  // the same vertices lie on it in both (each tile's texture patches may
  // repeat a vertex, so compare the sets).
  int shared_borders = 0;
  const auto index_of = [](const std::string& name) {
    return std::make_pair(std::stoll(name.substr(0, name.find('_'))),
                          std::stoll(name.substr(name.find('_') + 1)));
  };
  for (const auto& [name, mesh] : finest)
    for (const auto& [other_name, other] : finest) {
      const auto [ix, iy] = index_of(name);
      const auto [jx, jy] = index_of(other_name);
      const int axis = jx == ix + 1 && jy == iy   ? 0
                       : jy == iy + 1 && jx == ix ? 1
                                                  : -1;
      if (axis < 0) continue;
      float border = std::numeric_limits<float>::max();
      for (const Eigen::Vector3f& p : other.positions)
        border = std::min(border, p[axis]);
      const auto on_border = [&](const engine::TexturedMesh& m) {
        std::set<std::tuple<float, float, float>> out;
        for (const Eigen::Vector3f& p : m.positions)
          if (p[axis] == border) out.insert({p.x(), p.y(), p.z()});
        return out;
      };
      const auto mine = on_border(mesh), theirs = on_border(other);
      std::size_t both = 0;
      for (const auto& v : mine) both += theirs.count(v);
      std::cout << name << " | " << other_name << ": " << mine.size() << " and "
                << theirs.size() << " vertices on the border, " << both
                << " in both" << std::endl;
      ++shared_borders;
      EXPECT_GT(theirs.size(), 10u);
      // A tile polygonises only the cells near points: where those end on
      // its border (the points stop short of it on the other side) its
      // surface has an edge there that the neighbour lacks, as one surface
      // over both would (MeshBuilder.TheTilesTogetherAreTheSurfaceMadeAsOne),
      // so one side may hold many vertices the other lacks. But where both
      // have surface they meet vertex for vertex: the side with fewer
      // vertices on the border has nearly all of them in the other (a crack
      // would share none).
      EXPECT_GE(both, std::min(mine.size(), theirs.size()) * 97 / 100)
          << name << " and " << other_name;
    }
  EXPECT_GT(shared_borders, 0);
  std::cout << shared_borders << " shared tile borders checked" << std::endl;
}

// Past `inline_global_ba_images` the global adjustment leaves the increment:
// the worker runs it while the site has no work waiting, publishes the
// refined poses, and a dense phase moves the depth maps after them. Each
// capture's features are stored once, beside a state blob without them,
// and a restarted worker continues from both.
TEST(EngineWorker,
     RefinementIsFollowedByTheDenseCloudAndStateKeepsFeaturesApart) {
  auto store = db::Store::open(testing::fresh_sqlite_url());
  const std::string dir = render_street(*store, 8);
  engine::WorkerOptions options;
  options.reconstruction.inline_global_ba_images = 3;
  std::mutex lines_mutex;
  std::vector<std::string> lines;
  options.progress = [&](const std::string& line) {
    std::lock_guard lock(lines_mutex);
    lines.push_back(line);
  };
  engine::EngineWorker worker(*store, options);
  worker.start();
  const auto all = upload_street(*store, dir);
  ASSERT_TRUE(worker.wait_idle(std::chrono::minutes(5)));
  worker.stop();
  // A refinement ran, and a dense phase came after the last one.
  int last_refinement = -1, last_dense = -1;
  for (size_t i = 0; i < lines.size(); ++i) {
    if (lines[i].find("global refinement") != std::string::npos)
      last_refinement = static_cast<int>(i);
    if (lines[i].find(": dense ") != std::string::npos)
      last_dense = static_cast<int>(i);
  }
  ASSERT_GE(last_refinement, 0);
  EXPECT_GT(last_dense, last_refinement);
  const auto sites = store->list_children("/sites");
  ASSERT_EQ(sites.size(), 1u);
  const auto model = store->get(sites[0].path + "/model");
  ASSERT_TRUE(model);
  EXPECT_EQ(model->attrs.value("dense_state", ""), "current");
  EXPECT_EQ(model->attrs.at("statistics").value("registered", 0), 8);

  // Features once per capture; the state blob is a fraction of them.
  const auto features = store->list_children(sites[0].path + "/features");
  EXPECT_EQ(features.size(), all.size());
  size_t feature_bytes = 0;
  for (const db::Document& doc : features)
    feature_bytes += store->get_blob(doc.blobs.at("features")).size();
  const auto state = store->get(sites[0].path + "/engine");
  ASSERT_TRUE(state);
  size_t state_bytes = 0;  // its parts (engine/service/src/state_parts.h)
  for (const auto& [name, sha] : state->blobs)
    state_bytes += store->get_blob(sha).size();
  EXPECT_GT(state_bytes, 0u);
  std::cout << "features " << feature_bytes << " bytes, state " << state_bytes
            << " bytes" << std::endl;
  EXPECT_LT(state_bytes, feature_bytes / 2);
  const auto restored = engine::load_site_reconstruction(
      *store, sites[0].path.substr(std::string("/sites/").size()));
  ASSERT_TRUE(restored);
  EXPECT_EQ(restored->model().images.size(), 8u);

  // A restarted worker restores the site and takes a withdrawal; the
  // withdrawn capture's features go with it.
  engine::EngineWorker again(*store, engine::WorkerOptions{});
  again.start();
  const std::string withdrawn = "alice-" + all[5].stem().string();
  store->patch("/captures/" + withdrawn, Json{{"status", "withdrawn"}});
  ASSERT_TRUE(again.wait_idle(std::chrono::minutes(5)));
  again.stop();
  EXPECT_FALSE(store->get(sites[0].path + "/features/" + withdrawn));
  EXPECT_EQ(store->list_children(sites[0].path + "/features").size(),
            all.size() - 1);
  const auto after = store->get(sites[0].path + "/model");
  EXPECT_EQ(after->attrs.at("statistics").value("registered", 0), 7);
}

// While a site's dense lane has work left over (views to sweep, moved maps
// to re-fuse), its phases store the depth maps but leave the tiles to a
// later phase (WorkerOptions::dense_tile_interval, here an hour): only the
// lane's first phase and those with nothing left over write tiles, and the
// cloud ends current, the tiles holding every point the model counts.
TEST(EngineWorker, DenseTilesWaitWhileTheLaneHasWorkLeftOver) {
  auto store = db::Store::open(testing::fresh_sqlite_url());
  const std::string dir = render_street(*store, 8);
  engine::WorkerOptions options;
  options.dense_tile_interval = std::chrono::hours(1);
  options.dense_options.sweep_budget = 1;  // one view a phase: work left
  std::mutex lines_mutex;
  int phases = 0, left_over = 0;
  options.progress = [&](const std::string& line) {
    if (line.find(": dense ") == std::string::npos) return;
    std::lock_guard lock(lines_mutex);
    ++phases;
    if (line.find("to sweep next") != std::string::npos ||
        line.find("left for later") != std::string::npos)
      ++left_over;
  };
  engine::EngineWorker worker(*store, options);
  worker.start();
  upload_street(*store, dir);
  ASSERT_TRUE(worker.wait_idle(std::chrono::minutes(5)));
  worker.stop();
  std::set<std::int64_t> tile_commits, map_commits;
  for (const db::Change& c : store->changes(0, "/**", 100000)) {
    if (c.op != db::OpType::kPut) continue;
    if (c.kind == "dense-tile") tile_commits.insert(c.time_us);
    if (c.kind == "depth-map") map_commits.insert(c.time_us);
  }
  std::cout << phases << " dense phases, " << left_over
            << " with work left over; tiles written by " << tile_commits.size()
            << ", depth maps by " << map_commits.size() << std::endl;
  ASSERT_GE(left_over, 2);
  EXPECT_LE(static_cast<int>(tile_commits.size()), phases - left_over + 1);
  EXPECT_GT(map_commits.size(), tile_commits.size());
  const auto sites = store->list_children("/sites");
  ASSERT_EQ(sites.size(), 1u);
  const auto model = store->get(sites[0].path + "/model");
  ASSERT_TRUE(model);
  EXPECT_EQ(model->attrs.value("dense_state", ""), "current");
  const auto cloud =
      engine::load_dense_cloud(*store, engine::dense_cloud_blobs(*model));
  EXPECT_GT(cloud.size(), 20000u);
  EXPECT_LE(
      cloud.size(),
      model->attrs.at("statistics").value("dense_points", std::size_t{0}));
}

// While photos keep coming, increments leave the engine state unsaved
// (WorkerOptions::state_interval) and their captures in flight: the
// checkpoint stays below them. A worker stopped then (here once the last
// photo shows registered; its quiet_save_after is an hour, so no quiet
// save can slip in before the stop however slow the machine) loses
// nothing: the next one redoes the unsaved work from the last saved
// state, saves it once the site is quiet, and the checkpoint passes every
// capture.
TEST(EngineWorker, UnsavedStateKeepsTheCheckpointBackAndARestartRedoesIt) {
  auto store = db::Store::open(testing::fresh_sqlite_url());
  const std::string dir = render_street(*store, 8);
  engine::WorkerOptions options;
  options.dense = false;
  options.state_interval = std::chrono::hours(1);
  std::mutex lines_mutex;
  std::vector<std::string> lines;
  options.progress = [&](const std::string& line) {
    std::lock_guard lock(lines_mutex);
    lines.push_back(line);
  };
  const auto registered = [&]() {
    for (const db::Document& site : store->list_children("/sites"))
      if (auto model = store->get(site.path + "/model"))
        return model->attrs.at("statistics").value("registered", 0);
    return 0;
  };
  {
    engine::WorkerOptions busy = options;
    busy.quiet_save_after = std::chrono::hours(1);
    engine::EngineWorker worker(*store, busy);
    worker.start();
    upload_street(*store, dir);
    const auto deadline =
        std::chrono::steady_clock::now() + std::chrono::minutes(5);
    while (registered() < 8 && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    ASSERT_EQ(registered(), 8);
    EXPECT_LT(store->load_checkpoint("engine"),
              store->last_change("/captures/*"));
    worker.stop();
  }
  {
    std::lock_guard lock(lines_mutex);
    EXPECT_TRUE(std::any_of(lines.begin(), lines.end(), [](const auto& l) {
      return l.find("(the state unsaved)") != std::string::npos;
    }));
    lines.clear();
  }
  engine::EngineWorker again(*store, options);
  again.start();
  ASSERT_TRUE(again.wait_idle(std::chrono::minutes(5)));
  again.stop();
  std::lock_guard lock(lines_mutex);
  const auto said = [&](const std::string& what) {
    return std::any_of(lines.begin(), lines.end(), [&](const auto& l) {
      return l.find(what) != std::string::npos;
    });
  };
  EXPECT_TRUE(said(": +")) << "nothing redone";
  EXPECT_TRUE(said("engine state saved"));
  EXPECT_EQ(registered(), 8);
  EXPECT_EQ(store->load_checkpoint("engine"),
            store->last_change("/captures/*"));
  const auto sites = store->list_children("/sites");
  ASSERT_EQ(sites.size(), 1u);
  const auto restored = engine::load_site_reconstruction(
      *store, sites[0].path.substr(std::string("/sites/").size()));
  ASSERT_TRUE(restored);
  EXPECT_EQ(restored->model().images.size(), 8u);
}

// The model's cameras as the evaluator's poses, by photo name: the
// capture id less its scout ("alice-0007" is 0007.jpg).
std::map<std::string, eval::Pose> model_poses(const Json& model) {
  std::map<std::string, eval::Pose> poses;
  for (const Json& image : model.at("images")) {
    const std::string id = image.at("id").get<std::string>();
    const std::string name = id.substr(id.find('-') + 1) + ".jpg";
    const auto q = image.at("qvec").get<std::array<double, 4>>();
    const auto t = image.at("tvec").get<std::array<double, 3>>();
    eval::Pose pose;
    pose.name = name;
    pose.R = Eigen::Quaterniond(q[0], q[1], q[2], q[3]).toRotationMatrix();
    pose.t = Eigen::Vector3d(t[0], t[1], t[2]);
    poses[name] = pose;
  }
  return poses;
}

// Two scouts walk a loop round a small block at once, each their own half
// (bench/service_bench --split): bob starts on the far side, where nothing
// alice photographs reaches, so his photos start a component of their own
// (placed by their fixes) instead of waiting; where the walks meet, the
// components merge. With a site radius of 5 m, bob's first photo (about
// 20 m from alice's) founds a site of its own, and the two sites become
// one where the walks meet (docs/service.md, "Sites that grow together").
// In the end: one site (the other saying where it went), one component,
// every photo registered, each capture naming the component, the cameras
// as accurate as one scout's walk gives (docs/engine.md, "Components").
TEST(EngineWorker, TwoScoutsSplittingAWalkEndInOneComponent) {
  constexpr int kViews = 60;
  auto store = db::Store::open(testing::fresh_sqlite_url());
  const std::string dir = testing::make_temp_dir("split_walk");
  const std::string command =
      std::string(ARSCOUT_CLI) +
      " render-site --scene block --width 640 --height 480 --seed 7 --views " +
      std::to_string(kViews) + " --out " + dir + " > " + dir +
      "/render.log 2>&1";
  ASSERT_EQ(std::system(command.c_str()), 0) << command;
  testing::put_calibrated_camera(
      *store, "synthetic",
      engine::read_k_matrix(dir + "/images/K.txt", 640, 480));
  std::mutex seen_mutex;
  size_t most_components = 0;
  // Component ids only grow (a new one takes the next id; a merge keeps
  // one of the two): an id above 0 means a second component was started,
  // even when the version that showed two at once was overtaken before
  // this subscriber read it.
  int highest_id = 0;
  auto models = store->subscribe(
      "/sites/*/model", store->last_seq(), [&](const db::Change& change) {
        auto doc = store->get(change.path);
        if (!doc) return;
        std::lock_guard lock(seen_mutex);
        const Json components = doc->attrs.value("components", Json::array());
        most_components = std::max(most_components, components.size());
        for (const Json& c : components)
          highest_id = std::max(highest_id, c.value("id", 0));
      });
  engine::WorkerOptions options;
  options.dense = false;
  options.site_radius_m = 5;
  std::mutex lines_mutex;
  std::vector<std::string> progress;  // the worker's lines, all printed on
                                      // a failure, the site merges always
  options.progress = [&](const std::string& line) {
    std::lock_guard lock(lines_mutex);
    progress.push_back(line);
  };

  engine::EngineWorker worker(*store, options);
  worker.start();
  const auto fixes = metadata::read_gps_csv(dir + "/gps.csv");
  const auto all = photos(dir + "/images");
  ASSERT_EQ(all.size(), static_cast<size_t>(kViews));
  for (int i = 0; i < kViews / 2; ++i) {
    for (const auto& [scout, k] :
         {std::pair{"alice", i}, std::pair{"bob", i + kViews / 2}}) {
      upload(*store, scout, all[k], fixes.at(all[k].filename().string()),
             "synthetic");
    }
  }
  ASSERT_TRUE(worker.wait_idle(std::chrono::minutes(15)));
  worker.stop();
  models->stop();
  std::vector<db::Document> live, merged;
  for (const db::Document& site : store->list_children("/sites"))
    (site.attrs.value("state", "") == "merged" ? merged : live).push_back(site);
  ASSERT_EQ(live.size(), 1u);
  ASSERT_EQ(merged.size(), 1u) << "bob never had a site of his own";
  const std::string kept = live[0].path.substr(std::string("/sites/").size());
  EXPECT_EQ(merged[0].attrs.value("merged_into", ""), kept);
  EXPECT_EQ(merged[0].attrs.value("capture_count", -1), 0);
  EXPECT_FALSE(store->get(merged[0].path + "/model"));
  EXPECT_FALSE(store->get(merged[0].path + "/engine"));
  EXPECT_TRUE(store->list_children(merged[0].path + "/features").empty());
  EXPECT_EQ(live[0].attrs.value("capture_count", 0), kViews);
  EXPECT_EQ(worker.stats().sites_merged, 1);
  for (const std::string& line : progress) {
    if (line.find("took in site") != std::string::npos)
      std::cout << line << std::endl;
  }
  const auto model = store->get(live[0].path + "/model");
  ASSERT_TRUE(model);
  const Json& components = model->attrs.at("components");
  std::cout << "split walk: " << model->attrs.at("statistics").dump()
            << ", components " << components.dump() << ", at most "
            << most_components << " at once" << std::endl;
  EXPECT_EQ(model->attrs.at("statistics").value("registered", 0), kViews);
  ASSERT_EQ(components.size(), 1u);
  EXPECT_TRUE(most_components >= 2 || highest_id >= 1)
      << "bob's half never had its own component";
  const int component = components[0].value("id", -1);
  EXPECT_EQ(store->list_children(live[0].path + "/features").size(),
            static_cast<size_t>(kViews));
  for (const db::Document& capture : store->list_children("/captures")) {
    EXPECT_EQ(capture.attrs.value("site", ""), kept) << capture.path;
    EXPECT_EQ(capture.attrs.value("status", ""), "registered") << capture.path;
    EXPECT_EQ(capture.attrs.value("component", -1), component) << capture.path;
  }
  const eval::PoseComparison poses = eval::compare_to_ground_truth(
      model_poses(model->attrs),
      eval::read_strecha_ground_truth(dir + "/gt_dense_cameras"));
  std::cout << "split walk: " << poses.matched << "/" << kViews
            << " registered, centre error median " << poses.median_centre_error
            << " m, max " << poses.max_centre_error << " m" << std::endl;
  EXPECT_EQ(poses.matched, kViews);
  EXPECT_LE(poses.median_centre_error, 0.02);
  EXPECT_LE(poses.max_centre_error, 0.10);
  if (!HasFailure()) {
    fs::remove_all(dir);
    return;
  }
  for (const auto& camera : poses.cameras)
    std::cout << camera.name << " " << camera.centre_error << " m\n";
  for (const std::string& line : progress) std::cout << line << "\n";
}

// Photos with neither a fix nor a site hint (location denied on the phone):
// carol's first waits "for a position" (not rejected) and follows her next
// photo, taken a minute later with a fix; dave's, taken while alice's
// photos went into the fountain's site, stays waiting: no photo of his is
// placed. On the way, the site's default name and a rename the engine
// keeps.
TEST(EngineWorker, PhotosWithoutAFixFollowTheirScoutsPhotos) {
  std::string fountain, url;
  ARSCOUT_SHARED_DATA_OR_SKIP(fountain, "strecha/fountain-P11");
  ARSCOUT_FRESH_STORE_OR_SKIP(url, "sqlite");
  auto store = db::Store::open(url);
  testing::put_calibrated_camera(
      *store, "fountain",
      engine::read_k_matrix(fountain + "/images/K.txt", 3072, 2048),
      Json::array({0, 0, 0, 0, 0}));
  engine::WorkerOptions options;
  options.dense = false;
  engine::EngineWorker worker(*store, options);
  worker.start();
  const auto fixes = metadata::read_gps_csv(fountain + "/gps.csv");
  const std::vector<fs::path> all = photos(fountain + "/images");
  // As the API stores them: `taken` from the photo, no `gps` without a fix.
  const auto put = [&](const std::string& scout, const fs::path& p,
                       const std::string& taken, bool with_fix) {
    Json attrs = {{"scout", scout},
                  {"filename", p.filename().string()},
                  {"taken", taken},
                  {"camera", "fountain"},
                  {"status", with_fix ? "stored" : "needs-gps"},
                  {"status_reason", ""}};
    if (with_fix)
      attrs["gps"] = metadata::to_json(fixes.at(p.filename().string()));
    db::WriteOp op = db::WriteOp::put(
        "/captures/" + scout + "-" + p.stem().string(), "capture", attrs, 0);
    op.blobs = db::BlobRefs{{"image", store->put_blob(read_file(p))}};
    store->batch({op});
  };
  for (std::size_t i = 0; i < 8; ++i)
    put("alice", all[i], "2026-12-06T10:00:0" + std::to_string(i) + "Z", true);
  put("carol", all[8], "2026-12-06T10:01:00Z", false);
  put("dave", all[9], "2026-12-06T10:01:00Z", false);
  ASSERT_TRUE(worker.wait_idle(std::chrono::minutes(5)));
  const auto status = [&](const std::string& id) {
    return store->get("/captures/" + id)->attrs;
  };
  EXPECT_EQ(status("carol-0008").value("status", ""), "needs-gps");
  EXPECT_NE(status("carol-0008")
                .value("status_reason", "")
                .find("waiting for a position"),
            std::string::npos);
  // A readable default name (founding scout and time), then a planner's
  // rename, which the engine's later commits keep.
  const std::string site_path =
      "/sites/" + status("alice-0000").value("site", "");
  EXPECT_EQ(store->get(site_path)->attrs.value("name", ""),
            "alice 2026-12-06 10:00");
  db::WriteOp rename =
      db::WriteOp::patch(site_path, Json{{"name", "Fountain"}});
  rename.author = "pat";
  store->batch({rename});
  put("carol", all[10], "2026-12-06T10:02:00Z", true);
  ASSERT_TRUE(worker.wait_idle(std::chrono::minutes(5)));
  worker.stop();
  const std::string site = status("alice-0000").value("site", "");
  ASSERT_FALSE(site.empty());
  for (const char* id : {"carol-0008", "carol-0010"}) {
    EXPECT_EQ(status(id).value("site", ""), site) << id;
    EXPECT_EQ(status(id).value("status", ""), "registered") << id;
  }
  EXPECT_EQ(status("dave-0009").value("status", ""), "needs-gps");
  EXPECT_TRUE(status("dave-0009").value("site", "").empty());
  const auto renamed = store->get(site_path);
  EXPECT_EQ(renamed->attrs.value("name", ""), "Fountain");
  EXPECT_EQ(renamed->author, "engine");  // written by the engine since
}

}  // namespace
}  // namespace arscout
