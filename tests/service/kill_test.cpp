// The engine killed with SIGKILL three times at random moments while a
// scout uploads fountain-P11: after the last restart every capture is
// processed, nothing twice, and the model matches an uninterrupted run
// (same registered set, camera centres within 1 mm). The engine runs as
// `arscout engine`, a process of its own, on a SQLite file.
#include <gtest/gtest.h>

#include <csignal>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <random>
#include <sstream>
#include <thread>

#include "arscout/db/store.h"
#include "arscout/engine/camera.h"
#include "arscout/engine/service.h"
#include "arscout/metadata/gps.h"
#include "camera_document.h"
#include "test_stores.h"
#include "tool_process.h"

namespace arscout {
namespace {

namespace fs = std::filesystem;
using db::Json;
using namespace std::chrono_literals;

std::string read_file(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream bytes;
  bytes << in.rdbuf();
  return bytes.str();
}

struct Scene {
  std::vector<fs::path> photos;
  std::map<std::string, metadata::GpsFix> fixes;
  engine::CameraIntrinsics camera;
};

void put_camera(db::Store& store, const engine::CameraIntrinsics& K) {
  testing::put_calibrated_camera(store, "fountain", K);
}

void upload(db::Store& store, const Scene& scene, size_t i) {
  const fs::path& photo = scene.photos[i];
  db::WriteOp op = db::WriteOp::put(
      "/captures/" + photo.stem().string(), "capture",
      Json{
          {"scout", "alice"},
          {"camera", "fountain"},
          {"gps", metadata::to_json(scene.fixes.at(photo.filename().string()))},
          {"status", "stored"}},
      0);
  op.blobs = db::BlobRefs{{"image", store.put_blob(read_file(photo))}};
  store.batch({op});
}

// Camera centres by capture id, from the site's model document.
std::map<std::string, std::array<double, 3>> centres(db::Store& store) {
  std::map<std::string, std::array<double, 3>> out;
  for (const db::Document& site : store.list_children("/sites")) {
    auto model = store.get(site.path + "/model");
    if (!model) continue;
    for (const Json& image : model->attrs.at("images"))
      out[image.at("id").get<std::string>()] =
          image.at("centre").get<std::array<double, 3>>();
  }
  return out;
}

TEST(EngineKill, ThreeKillsLoseNothingAndChangeNothing) {
  std::string dir;
  ARSCOUT_SHARED_DATA_OR_SKIP(dir, "strecha/fountain-P11");
  Scene scene;
  for (const auto& e : fs::directory_iterator(dir + "/images"))
    if (e.path().extension() == ".jpg") scene.photos.push_back(e.path());
  std::sort(scene.photos.begin(), scene.photos.end());
  scene.fixes = metadata::read_gps_csv(dir + "/gps.csv");
  scene.camera = engine::read_k_matrix(dir + "/images/K.txt", 3072, 2048);

  // The uninterrupted run, in process.
  auto reference_store = db::Store::open(testing::fresh_sqlite_url());
  put_camera(*reference_store, scene.camera);
  {
    engine::EngineWorker worker(*reference_store, {});
    worker.start();
    for (size_t i = 0; i < scene.photos.size(); ++i)
      upload(*reference_store, scene, i);
    ASSERT_TRUE(worker.wait_idle(10min));
  }
  const auto reference = centres(*reference_store);
  ASSERT_EQ(reference.size(), scene.photos.size());

  // The killed run: `arscout engine` as a process, killed three times.
  const std::string work = testing::make_temp_dir("engine_kill");
  const std::string url = "sqlite:" + work + "/store.db";
  auto store = db::Store::open(url);
  put_camera(*store, scene.camera);
  // At info the log says what the engine did (its progress lines). The
  // state is saved at every increment, so that a restart redoes one
  // increment, as the uninterrupted run made it: with unsaved state a
  // restart redoes more photos in other batches, and the model may differ
  // by more than the 1 mm asked here (that redo is tested in
  // EngineWorker.UnsavedStateKeepsTheCheckpointBackAndARestartRedoesIt).
  const std::vector<std::string> args = {
      "--log-level", "info", "engine", "--db", url, "--state-interval", "0"};
  auto engine = std::make_unique<testing::ToolProcess>(ARSCOUT_CLI, args,
                                                       work + "/engine.log");
  std::thread scout([&] {
    for (size_t i = 0; i < scene.photos.size(); ++i) {
      upload(*store, scene, i);
      std::this_thread::sleep_for(1s);
    }
  });
  std::mt19937 rng(20261121);
  std::uniform_int_distribution<int> pause_ms(1500, 5000);
  for (int kill = 1; kill <= 3; ++kill) {
    std::this_thread::sleep_for(std::chrono::milliseconds(pause_ms(rng)));
    const int status = engine->kill_now();
    std::cout << "kill " << kill << ": " << testing::describe_status(status)
              << ", checkpoint " << store->load_checkpoint("engine") << " of "
              << store->last_change("/captures/*") << std::endl;
    engine = std::make_unique<testing::ToolProcess>(ARSCOUT_CLI, args,
                                                    work + "/engine.log");
  }
  scout.join();
  // Caught up: the checkpoint covers every capture change, for 2 s.
  int steady = 0;
  for (auto deadline = std::chrono::steady_clock::now() + 10min;
       steady < 4 && std::chrono::steady_clock::now() < deadline;) {
    std::this_thread::sleep_for(500ms);
    const bool caught_up =
        store->load_checkpoint("engine") >= store->last_change("/captures/*");
    steady = caught_up ? steady + 1 : 0;
  }
  engine->signal(SIGTERM);
  engine->wait_for(60s);
  ASSERT_EQ(steady, 4) << testing::slurp(work + "/engine.log");

  const auto killed = centres(*store);
  ASSERT_EQ(killed.size(), reference.size())
      << testing::slurp(work + "/engine.log");
  double worst = 0;
  for (const auto& [id, c] : reference) {
    ASSERT_TRUE(killed.count(id)) << id << " not registered after the kills";
    const auto& k = killed.at(id);
    const double d = std::hypot(c[0] - k[0], c[1] - k[1], c[2] - k[2]);
    worst = std::max(worst, d);
    EXPECT_LE(d, 1e-3) << id;
  }
  std::cout << "largest centre difference " << worst * 1000 << " mm"
            << std::endl;
  // Every capture registered once: one site, its list without repeats.
  const auto sites = store->list_children("/sites");
  ASSERT_EQ(sites.size(), 1u);
  const Json captures = sites[0].attrs.at("captures");
  EXPECT_EQ(captures.size(), scene.photos.size()) << captures.dump();
  for (const auto& p : scene.photos) {
    auto doc = store->get("/captures/" + p.stem().string());
    ASSERT_TRUE(doc);
    EXPECT_EQ(doc->attrs.value("status", ""), "registered") << p;
  }
}

}  // namespace
}  // namespace arscout
