// Recorded sessions (ingest/session.h): export a store's change log with
// the scouts' inputs, replay it into an empty store through the API's
// handlers, and get the same captures, photos, cameras and withdrawals;
// refuse damaged files before applying anything.
#include <chrono>
#include <fstream>
#include <sstream>
#include <thread>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "api.h"
#include "arscout/db/store.h"
#include "arscout/ingest/auth.h"
#include "arscout/ingest/session.h"
#include "test_stores.h"

namespace arscout::ingest {
namespace {

using namespace std::chrono_literals;

std::string photo(int seed) {
  cv::Mat image(90, 120, CV_8UC3, cv::Scalar(seed * 41 % 255, 80, 170));
  cv::circle(image, {30 + seed * 7 % 60, 45}, 15, cv::Scalar(0, 0, 0), -1);
  std::vector<uchar> out;
  cv::imencode(".jpg", image, out);
  return std::string(out.begin(), out.end());
}

HttpRequest request(const std::string& method, const std::string& path,
                    const std::string& token, const std::string& body = "") {
  HttpRequest r;
  r.method = method;
  r.path = r.target = path;
  r.headers["authorization"] = "Bearer " + token;
  r.body = body;
  return r;
}

// What a replay must reproduce of a capture: everything the scout sent and
// the server derived from it, not when it arrived.
Json comparable(const db::Document& doc) {
  Json attrs = doc.attrs;
  attrs.erase("received");
  return Json{{"attrs", attrs}, {"blobs", doc.blobs}, {"author", doc.author}};
}

class SessionTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing::make_temp_dir("session");
    source_ = db::Store::open("sqlite:" + dir_ + "/source.db");
    target_ = db::Store::open("sqlite:" + dir_ + "/target.db");
    alice_ = create_token(*source_, Role::kScout, "alice");
    bob_ = create_token(*source_, Role::kScout, "bob");
    Api api(*source_, metrics_);
    ASSERT_EQ(api.handle(request("PUT", "/v1/cameras/phone", alice_,
                                 R"({"fx": 100, "fy": 100, "cx": 60, "cy": 45,
                                     "width": 120, "height": 90,
                                     "distortion": [0, 0, 0, 0, 0],
                                     "source": "calibrated"})"))
                  .status,
              201);
    for (int i = 0; i < 4; ++i) {
      const std::string& token = i % 2 ? bob_ : alice_;
      HttpRequest up = request("POST", "/v1/captures", token, photo(i));
      up.headers["content-type"] = "image/jpeg";
      Json meta{{"capture_id", "c" + std::to_string(i)}, {"camera", "phone"}};
      if (i != 3) meta["gps"] = {{"lat", 47 + i * 1e-4}, {"lon", 15.4}};
      up.headers["x-capture-metadata"] = meta.dump();
      ASSERT_EQ(api.handle(up).status, 201);
      std::this_thread::sleep_for(150ms);  // a rhythm to keep
    }
    // The engine's kind of write: not an input, recomputed on replay.
    db::WriteOp engine_patch = db::WriteOp::patch(
        "/captures/alice.c0", {{"site", "s-1"}, {"status", "registered"}});
    engine_patch.author = "engine";
    source_->write(engine_patch);
    source_->put("/sites/s-1", "site", {{"name", "s-1"}});
    ASSERT_EQ(api.handle(request("DELETE", "/v1/captures/bob.c1", bob_)).status,
              200);
  }

  std::string export_to_file() {
    const std::string path = dir_ + "/s.session";
    std::ofstream out(path);
    export_session(*source_, 0, out);
    return path;
  }

  std::string dir_;
  std::unique_ptr<db::Store> source_, target_;
  std::string alice_, bob_;
  Metrics metrics_;
};

TEST_F(SessionTest, ReplayReproducesTheScoutsInputsAndNotTheEnginesOutputs) {
  const std::string path = export_to_file();
  const ReplaySummary s = replay_session(path, *target_, {});
  EXPECT_EQ(s.captures, 4);
  EXPECT_EQ(s.withdrawals, 1);
  EXPECT_EQ(s.cameras, 1);
  EXPECT_EQ(s.failed, 0);
  for (const char* id : {"alice.c0", "alice.c2", "bob.c3"}) {
    const auto a = source_->get(std::string("/captures/") + id);
    const auto b = target_->get(std::string("/captures/") + id);
    ASSERT_TRUE(b) << id;
    Json expected = comparable(*a);
    if (std::string(id) == "alice.c0") {  // as uploaded, before the engine
      expected["attrs"]["status"] = "stored";
      expected["attrs"].erase("site");
      expected["author"] = "alice";
    }
    EXPECT_EQ(comparable(*b), expected) << id;
    EXPECT_EQ(target_->get_blob(b->blobs.at("image")),
              source_->get_blob(a->blobs.at("image")));
  }
  EXPECT_EQ(target_->get("/captures/bob.c1")->attrs.at("status"), "withdrawn");
  EXPECT_EQ(target_->get("/captures/bob.c1")->attrs.at("status_reason"),
            "withdrawn by bob");
  EXPECT_EQ(target_->get("/captures/bob.c3")->attrs.at("status"), "needs-gps");
  EXPECT_EQ(target_->get("/cameras/alice.phone")->attrs,
            source_->get("/cameras/alice.phone")->attrs);
  EXPECT_FALSE(target_->get("/sites/s-1"));
  // The recorded rhythm: 3 gaps of >= 150 ms between the uploads.
  EXPECT_GE(s.seconds, 0.4);

  // Twice is once: the capture ids make the uploads idempotent.
  const std::int64_t seq = target_->last_seq();
  ReplayOptions fast;
  fast.fast = true;
  const ReplaySummary again = replay_session(path, *target_, fast);
  EXPECT_EQ(again.failed, 0);
  EXPECT_LT(again.seconds, 0.4);
  EXPECT_EQ(target_->last_seq(), seq);
}

TEST_F(SessionTest, SpeedDividesTheInterArrivalTimes) {
  const std::string path = export_to_file();
  ReplayOptions quick;
  quick.speed = 10;
  const ReplaySummary s = replay_session(path, *target_, quick);
  EXPECT_EQ(s.captures, 4);
  EXPECT_LT(s.seconds, 0.4);
}

TEST_F(SessionTest, DamagedFilesAreRefusedBeforeAnythingIsApplied) {
  const std::string path = export_to_file();
  std::stringstream whole;
  whole << std::ifstream(path).rdbuf();
  const std::string text = whole.str();
  auto refused = [&](const std::string& bytes, const std::string& why) {
    const std::string damaged = dir_ + "/damaged.session";
    std::ofstream(damaged, std::ios::trunc) << bytes;
    const std::int64_t seq = target_->last_seq();
    try {
      replay_session(damaged, *target_, {});
      ADD_FAILURE() << "accepted: " << why;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
    }
    EXPECT_EQ(target_->last_seq(), seq) << why;
  };
  refused(text.substr(0, text.size() / 2), "");
  refused(text.substr(0, text.rfind("{\"blobs\"")), "truncated");
  refused("not json\n", "not a JSON object");
  refused("{\"type\":\"session\",\"format\":\"other\"}\n",
          "not an arscout session");
  std::string extra = text;
  extra.insert(text.find('\n') + 1, "{\"type\":\"surprise\"}\n");
  refused(extra, "unknown record type");
  EXPECT_THROW(replay_session(dir_ + "/missing.session", *target_, {}),
               std::runtime_error);
}

// Round two, row 14: a crafted session stored a capture of a scout named
// "" (/captures/.z1), withdrew alice's capture in the name of a scout that
// never had it, and a gap of 10^18 us waited until the replay was killed.
// Each event is now taken as the API would take it from its scout, and the
// times are checked with the rest of the file before anything is applied.
TEST_F(SessionTest, CraftedEventsAreTakenOnlyAsTheApiWouldTakeThem) {
  const std::string path = export_to_file();
  std::vector<Json> records;
  for (std::ifstream in(path); in;) {
    std::string line;
    if (std::getline(in, line) && !line.empty())
      records.push_back(Json::parse(line));
  }
  const auto write = [&](const std::vector<Json>& lines) {
    const std::string crafted = dir_ + "/crafted.session";
    std::ofstream out(crafted, std::ios::trunc);
    for (const Json& j : lines) out << j.dump() << '\n';
    return crafted;
  };
  std::vector<Json> crafted = records;
  for (Json& j : crafted) {
    if (j.value("input", "") == "withdrawal") j["author"] = "mallory";
    if (j.value("path", "") == "/captures/alice.c2") {
      j["path"] = "/captures/.z1";
      j["attrs"]["scout"] = "";
    }
  }
  const ReplaySummary s = replay_session(write(crafted), *target_, {});
  EXPECT_EQ(s.failed, 2);
  EXPECT_FALSE(target_->get("/captures/.z1"));
  EXPECT_EQ(target_->get("/captures/bob.c1")->attrs.at("status"), "stored");

  std::vector<Json> endless = records;
  for (Json& j : endless)
    if (j.value("path", "") == "/captures/bob.c3")
      j["time_us"] = 1000000000000000000ll;
  const std::int64_t seq = target_->last_seq();
  const auto started = std::chrono::steady_clock::now();
  try {
    replay_session(write(endless), *target_, {});
    ADD_FAILURE() << "a session spanning 31,700 years was replayed";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("more than 30 days"),
              std::string::npos)
        << e.what();
  }
  EXPECT_LT(std::chrono::steady_clock::now() - started, 5s);
  EXPECT_EQ(target_->last_seq(), seq);
}

}  // namespace
}  // namespace arscout::ingest
