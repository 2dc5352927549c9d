// Database-level replay (docs/sessions.md): the fountain-P11 session the
// viewer_fountain fixture recorded (a real scout uploading 10 photos to a
// real server) is exported, replayed into an empty store with an engine
// following it, and must drive the engine to a model with the expected
// statistics. A failure prints the whole table, expected against got.
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <thread>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "arscout/db/store.h"
#include "arscout/engine/ply.h"
#include "arscout/engine/service.h"
#include "arscout/ingest/session.h"
#include "model_eval.h"
#include "test_stores.h"

namespace arscout {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

// One expected statistic: a name, what was measured, the allowed range.
struct Row {
  std::string name;
  double got;
  double min;
  double max;
  bool ok() const { return got >= min && got <= max; }
};

std::string table(const std::vector<Row>& rows) {
  std::ostringstream out;
  out << std::left << std::setw(34) << "statistic" << std::setw(14) << "got"
      << "expected\n";
  for (const Row& r : rows)
    out << std::setw(34) << r.name << std::setw(14) << r.got << "[" << r.min
        << ", " << r.max << "]" << (r.ok() ? "" : "   <-- FAILS") << "\n";
  return out.str();
}

// The model document of the only site, once it has `registered` captures
// and its dense cloud has caught up; nullopt at the timeout.
std::optional<db::Document> wait_for_model(db::Store& store, int registered,
                                           std::chrono::seconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < end) {
    for (const db::Document& site : store.list_children("/sites")) {
      auto model = store.get(site.path + "/model");
      if (model &&
          model->attrs.at("statistics").value("registered", 0) == registered &&
          model->attrs.value("dense_state", "") == "current")
        return model;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(250));
  }
  return std::nullopt;
}

double median_centre_error(const Json& model, const std::string& scene) {
  std::map<std::string, eval::Pose> estimated;
  for (const Json& image : model.at("images")) {
    const std::string id = image.at("id");
    eval::Pose pose;
    pose.name = id.substr(id.find('-') + 1);  // "alice-0003.jpg"
    const auto q = image.at("qvec").get<std::array<double, 4>>();
    const auto t = image.at("tvec").get<std::array<double, 3>>();
    pose.R = Eigen::Quaterniond(q[0], q[1], q[2], q[3]).toRotationMatrix();
    pose.t = Eigen::Vector3d(t[0], t[1], t[2]);
    estimated[pose.name] = pose;
  }
  return eval::compare_to_ground_truth(
             estimated,
             eval::read_strecha_ground_truth(scene + "/gt_dense_cameras"))
      .median_centre_error;
}

// The session file recorded from the viewer fixture's store, or "" after
// a skip or failure.
std::string record_fountain_session(const fs::path& dir) {
  const fs::path recorded(ARSCOUT_VIEWER_SITE);
  if (!fs::exists(recorded / "ready")) {
    const std::string why = "no recorded fountain site at " +
                            recorded.string() +
                            " (the viewer.fountain_site fixture failed?)";
    if (testing::in_ci()) ADD_FAILURE() << why;
    std::cout << "SKIP: " << why << std::endl;
    return "";
  }
  for (const char* name : {"arscout.db", "arscout.db-wal", "arscout.db-shm"})
    if (fs::exists(recorded / name)) fs::copy_file(recorded / name, dir / name);
  const std::string session = (dir / "fountain.session").string();
  auto source = db::Store::open("sqlite:" + (dir / "arscout.db").string());
  std::ofstream out(session);
  const ingest::SessionSummary s = ingest::export_session(*source, 0, out);
  EXPECT_EQ(s.inputs, 11);  // 10 photos and their camera
  return session;
}

// Replays `session` into a new store with an engine following it; the
// site's model once 10 captures are registered and the cloud is current.
std::optional<db::Document> replay_with_engine(
    const std::string& session, engine::WorkerOptions options,
    ingest::ReplayOptions replay, std::unique_ptr<db::Store>* store,
    ingest::ReplaySummary* summary) {
  *store = db::Store::open(testing::fresh_sqlite_url());
  options.dense_options.long_side = 480;  // as the recording's engine ran
  engine::EngineWorker worker(**store, options);
  worker.start();
  *summary = ingest::replay_session(session, **store, replay);
  auto model = wait_for_model(**store, 10, std::chrono::seconds(300));
  worker.stop();
  return model;
}

TEST(ReplayRegression, FountainSessionDrivesTheEngineToTheExpectedModel) {
  std::string scene;
  ARSCOUT_SHARED_DATA_OR_SKIP(scene, "strecha/fountain-P11");
  const fs::path dir = testing::make_temp_dir("replay");
  const std::string session = record_fountain_session(dir);
  if (session.empty()) GTEST_SKIP() << "no recorded session";

  // Replay into an empty store, an engine following it, at 4x speed.
  std::unique_ptr<db::Store> store;
  ingest::ReplayOptions replay;
  replay.speed = 4;
  ingest::ReplaySummary r;
  const auto model = replay_with_engine(session, {}, replay, &store, &r);
  ASSERT_TRUE(model) << "no model with 10 registered captures within 300 s";

  const Json& stats = model->attrs.at("statistics");
  const auto dense =
      engine::decode_ply(store->get_blob(model->blobs.at("dense")));
  const std::vector<Row> rows = {
      {"captures replayed", double(r.captures), 10, 10},
      {"inputs refused", double(r.failed), 0, 0},
      {"sites", double(store->list_children("/sites").size()), 1, 1},
      {"registered", stats.value("registered", 0.0), 10, 10},
      {"rejected", stats.value("rejected", 0.0), 0, 0},
      {"median centre error vs truth, mm",
       1000 * median_centre_error(model->attrs, scene), 0, 5},
      {"sparse points", stats.value("sparse_points", 0.0), 3500, 6500},
      // The recorded engine's cloud had 480 k points; increments fold
      // differently at another speed, so the cloud may differ somewhat.
      {"dense points", double(dense.size()), 330000, 630000},
  };
  const bool all_ok = std::all_of(rows.begin(), rows.end(),
                                  [](const Row& row) { return row.ok(); });
  std::cout << table(rows);
  EXPECT_TRUE(all_ok) << "\n" << table(rows);
}

TEST(ReplayDeterminism, TwoDeterministicReplaysGiveTheSameModel) {
  std::string scene;
  ARSCOUT_SHARED_DATA_OR_SKIP(scene, "strecha/fountain-P11");
  const fs::path dir = testing::make_temp_dir("replay-deterministic");
  const std::string session = record_fountain_session(dir);
  if (session.empty()) GTEST_SKIP() << "no recorded session";
  engine::WorkerOptions options;
  options.reconstruction.deterministic = true;
  ingest::ReplayOptions fast;
  fast.fast = true;
  std::unique_ptr<db::Store> a_store, b_store;
  ingest::ReplaySummary a_summary, b_summary;
  const auto a =
      replay_with_engine(session, options, fast, &a_store, &a_summary);
  // The second at real speed: arrival times must not matter.
  ingest::ReplayOptions paced;
  paced.speed = 2;
  const auto b =
      replay_with_engine(session, options, paced, &b_store, &b_summary);
  ASSERT_TRUE(a && b) << "no model with 10 registered captures within 300 s";

  const Json& ai = a->attrs.at("images");
  const Json& bi = b->attrs.at("images");
  ASSERT_EQ(ai.size(), bi.size());
  double worst = 0;
  for (size_t i = 0; i < ai.size(); ++i) {
    EXPECT_EQ(ai[i].at("id"), bi[i].at("id"));
    for (const char* key : {"qvec", "tvec"})
      for (size_t k = 0; k < ai[i].at(key).size(); ++k) {
        const double x = ai[i].at(key)[k], y = bi[i].at(key)[k];
        worst = std::max(worst, std::abs(x - y) / std::max(1.0, std::abs(x)));
      }
  }
  std::cout << "deterministic replays: largest relative pose difference "
            << worst << std::endl;
  EXPECT_LE(worst, 1e-9);
  EXPECT_EQ(a->attrs.at("statistics").at("sparse_points"),
            b->attrs.at("statistics").at("sparse_points"));
  EXPECT_EQ(a->attrs.at("statistics").at("dense_points"),
            b->attrs.at("statistics").at("dense_points"));
  EXPECT_EQ(a->attrs.at("captures"), b->attrs.at("captures"));
  EXPECT_EQ(a->version, b->version);
}

}  // namespace
}  // namespace arscout
