// Real scouting over loopback: four `arscout scout` processes upload the
// photos of ../shared/data/opensfm/lund (EXIF GPS) and strecha/fountain-P11
// (gps.csv) at once, two of them repeating another's uploads as a retrying
// device would. Each photo must be stored exactly once, with the right GPS.
#include <csignal>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <thread>

#include <gtest/gtest.h>

#include "arscout/db/store.h"
#include "arscout/ingest/auth.h"
#include "arscout/ingest/server.h"
#include "arscout/metadata/gps.h"
#include "test_stores.h"
#include "tool_process.h"

namespace arscout::ingest {

using metadata::GpsFix;
using metadata::read_exif_file;
using metadata::read_gps_csv;
namespace {

using namespace std::chrono_literals;
namespace fs = std::filesystem;

std::size_t count_images(const std::string& dir) {
  std::size_t n = 0;
  for (const auto& e : fs::directory_iterator(dir)) {
    std::string ext = e.path().extension().string();
    n += ext == ".jpg" || ext == ".JPG" || ext == ".png";
  }
  return n;
}

class ScoutsTest : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    ARSCOUT_SHARED_DATA_OR_SKIP(lund_, "opensfm/lund");
    ARSCOUT_SHARED_DATA_OR_SKIP(fountain_, "strecha/fountain-P11");
    ARSCOUT_FRESH_STORE_OR_SKIP(url_, GetParam());
    store_ = db::Store::open(url_);
    alice_ = create_token(*store_, Role::kScout, "alice");
    bob_ = create_token(*store_, Role::kScout, "bob");
    planner_ = create_token(*store_, Role::kPlanner, "pat");
    ServerOptions options;
    options.port = 0;
    server_ = std::make_unique<Server>(*store_, options);
    server_->start();
    dir_ = testing::make_temp_dir("scouts");
  }

  std::unique_ptr<testing::ToolProcess> scout(
      const std::string& token, const std::string& images,
      const std::string& log, std::vector<std::string> extra = {}) {
    std::vector<std::string> args = {
        "scout",
        "--server",
        "http://127.0.0.1:" + std::to_string(server_->port()),
        "--token",
        token,
        "--dir",
        images};
    args.insert(args.end(), extra.begin(), extra.end());
    return std::make_unique<testing::ToolProcess>(ARSCOUT_CLI, args,
                                                  dir_ + "/" + log);
  }

  std::string finish(testing::ToolProcess& p, const std::string& log) {
    auto status = p.wait_for(300s);
    if (!status) return "still running after 300 s";
    return testing::describe_status(*status) + "\n" +
           testing::slurp(dir_ + "/" + log);
  }

  std::string lund_, fountain_, url_, dir_;
  std::unique_ptr<db::Store> store_;
  std::unique_ptr<Server> server_;
  std::string alice_, bob_, planner_;
};

TEST_P(ScoutsTest, FourConcurrentScoutsStoreEachPhotoExactlyOnce) {
  const std::string lund_images = lund_ + "/images";
  const std::string fountain_images = fountain_ + "/images";
  const std::string csv = fountain_ + "/gps.csv";
  auto a1 = scout(alice_, lund_images, "a1.log");
  auto b1 = scout(bob_, fountain_images, "b1.log", {"--gps-csv", csv});
  auto a2 = scout(alice_, lund_images, "a2.log");  // the same photos again
  auto b2 = scout(bob_, fountain_images, "b2.log", {"--gps-csv", csv});
  for (auto [p, log] : {std::pair{a1.get(), "a1.log"},
                        {b1.get(), "b1.log"},
                        {a2.get(), "a2.log"},
                        {b2.get(), "b2.log"}}) {
    std::string result = finish(*p, log);
    EXPECT_EQ(result.rfind("exit 0", 0), 0u) << log << ": " << result;
  }

  const std::size_t lund_n = count_images(lund_images);
  const std::size_t fountain_n = count_images(fountain_images);
  db::Query all;
  all.pattern = "/captures/*";
  auto captures = store_->query(all);
  ASSERT_EQ(captures.size(), lund_n + fountain_n);
  // One change per capture: the repeats were replays, not new writes.
  EXPECT_EQ(store_->changes(0, "/captures/*", 100000).size(),
            lund_n + fountain_n);

  auto csv_fixes = read_gps_csv(csv);
  std::set<std::string> files;
  for (const auto& doc : captures) {
    const Json& a = doc.attrs;
    std::string file = a.value("filename", "");
    EXPECT_TRUE(files.insert(a.value("scout", "") + "/" + file).second) << file;
    ASSERT_TRUE(a.contains("gps")) << doc.path << " has no GPS";
    if (a["scout"] == "alice") {
      EXPECT_EQ(a["gps"]["source"], "exif") << doc.path;
      auto exif = read_exif_file(lund_images + "/" + file);
      ASSERT_TRUE(exif.gps) << file;
      EXPECT_NEAR(a["gps"]["lat"].get<double>(), exif.gps->lat, 1e-9);
      EXPECT_NEAR(a["gps"]["lon"].get<double>(), exif.gps->lon, 1e-9);
    } else {
      EXPECT_EQ(a["gps"]["source"], "request") << doc.path;
      const GpsFix& want = csv_fixes.at(file);
      EXPECT_NEAR(a["gps"]["lat"].get<double>(), want.lat, 1e-9) << file;
      EXPECT_NEAR(a["gps"]["lon"].get<double>(), want.lon, 1e-9) << file;
      EXPECT_NEAR(a["gps"]["h_acc"].get<double>(), *want.h_acc, 1e-9) << file;
    }
  }
  EXPECT_EQ(files.size(), lund_n + fountain_n);
}

// --camera-k stores the camera document from a K matrix before the first
// upload, for photos of the first photo's size; a K file that is not one
// stops the scout before anything is uploaded.
TEST_P(ScoutsTest, CameraKStoresTheCameraFirst) {
  const std::string images = fountain_ + "/images";
  auto ok = scout(bob_, images, "k.log",
                  {"--gps-csv", fountain_ + "/gps.csv", "--camera", "fp11",
                   "--camera-k", images + "/K.txt"});
  std::string result = finish(*ok, "k.log");
  ASSERT_EQ(result.rfind("exit 0", 0), 0u) << result;
  // bob's camera id is his own (/cameras/bob.fp11, docs/api.md).
  auto camera = store_->get("/cameras/bob.fp11");
  ASSERT_TRUE(camera);
  EXPECT_EQ(camera->attrs.value("width", 0), 3072);
  EXPECT_EQ(camera->attrs.value("height", 0), 2048);
  EXPECT_NEAR(camera->attrs.value("fx", 0.0), 2759.48, 0.01);
  EXPECT_EQ(camera->attrs.value("source", ""), "calibrated");
  // The camera was written before the first capture.
  const auto first_capture = store_->changes(0, "/captures/*", 1);
  ASSERT_EQ(first_capture.size(), 1u);
  EXPECT_LT(camera->seq, first_capture[0].seq);
  db::Query all;
  all.pattern = "/captures/*";
  for (const auto& doc : store_->query(all))
    EXPECT_EQ(doc.attrs.value("camera", ""), "bob.fp11") << doc.path;

  const std::string bad_k = dir_ + "/bad_K.txt";
  std::ofstream(bad_k) << "not a matrix\n";
  auto bad = scout(alice_, lund_ + "/images", "bad.log",
                   {"--camera", "x", "--camera-k", bad_k});
  result = finish(*bad, "bad.log");
  EXPECT_EQ(result.rfind("exit 2", 0), 0u) << result;
  EXPECT_FALSE(store_->get("/cameras/alice.x"));
  EXPECT_EQ(store_->query(all).size(), count_images(images));
}

TEST_P(ScoutsTest, WrongTokensAndPlannersStoreNothing) {
  const std::string images = lund_ + "/images";
  auto bogus = scout("ars_bogus", images, "bogus.log", {"--retries", "0"});
  auto planner = scout(planner_, images, "planner.log", {"--retries", "0"});
  std::string bogus_result = finish(*bogus, "bogus.log");
  std::string planner_result = finish(*planner, "planner.log");
  EXPECT_NE(bogus_result.rfind("exit 0", 0), 0u) << bogus_result;
  EXPECT_NE(bogus_result.find("401"), std::string::npos) << bogus_result;
  EXPECT_NE(planner_result.rfind("exit 0", 0), 0u) << planner_result;
  EXPECT_NE(planner_result.find("403"), std::string::npos) << planner_result;
  db::Query all;
  all.pattern = "/captures/*";
  EXPECT_TRUE(store_->query(all).empty());
}

// A camera syncing into a folder: --watch uploads each photo once it has
// fully arrived, and stops cleanly on SIGTERM.
TEST_P(ScoutsTest, WatchUploadsPhotosAsTheyAppear) {
  const std::string inbox = testing::make_temp_dir("inbox");
  auto watcher = scout(alice_, inbox, "watch.log", {"--watch"});
  std::vector<std::string> names = {"01.jpg", "02.jpg", "03.jpg"};
  // Let it scan the empty folder first, so the photos arrive while it
  // watches rather than in its first listing.
  std::this_thread::sleep_for(1500ms);
  for (const auto& name : names) {
    fs::copy_file(lund_ + "/images/" + name, inbox + "/" + name + ".part");
    fs::rename(inbox + "/" + name + ".part", inbox + "/" + name);
  }
  db::Query all;
  all.pattern = "/captures/*";
  auto deadline = std::chrono::steady_clock::now() + 60s;
  while (store_->query(all).size() < names.size() &&
         std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(100ms);
  watcher->signal(SIGTERM);
  std::string result = finish(*watcher, "watch.log");
  EXPECT_EQ(result.rfind("exit 0", 0), 0u) << result;
  auto captures = store_->query(all);
  ASSERT_EQ(captures.size(), names.size()) << result;
  std::set<std::string> stored;
  for (const auto& doc : captures)
    stored.insert(doc.attrs.value("filename", ""));
  EXPECT_EQ(stored, std::set<std::string>(names.begin(), names.end()));
}

INSTANTIATE_TEST_SUITE_P(Backends, ScoutsTest,
                         ::testing::Values("sqlite", "postgresql"),
                         [](const auto& info) { return info.param; });

}  // namespace
}  // namespace arscout::ingest
