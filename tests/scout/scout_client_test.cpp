// The scout's upload client (arscout/scout/scout.h) driven directly
// against an in-process server on a fresh SQLite store: where uploads land,
// retries and back-off (a route in front of POST /v1/captures answers 503
// on demand), which GPS goes with a photo, bad files, a refused token, and
// --watch. The sleep hook records the waits instead of sleeping them.
#include <atomic>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "arscout/db/store.h"
#include "arscout/ingest/auth.h"
#include "arscout/ingest/server.h"
#include "arscout/metadata/gps.h"
#include "arscout/scout/scout.h"
#include "test_stores.h"

namespace arscout::scout {

// The server the client talks to (ingest/) and what it speaks (http/).
using http::HttpRequest;
using http::HttpResponse;
using http::HttpResult;
using http::Json;
using ingest::ApiRoute;
using ingest::create_token;
using ingest::Principal;
using ingest::Role;
using ingest::Server;
using ingest::ServerOptions;
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

// ---- photos with EXIF, assembled byte by byte

std::string le(std::uint32_t v, int bytes) {
  std::string s;
  for (int i = 0; i < bytes; ++i) s += static_cast<char>((v >> (8 * i)) & 0xff);
  return s;
}

struct Entry {
  std::uint16_t tag;
  std::uint16_t type;  // 2 ASCII, 4 LONG, 5 RATIONAL
  std::uint32_t count;
  std::string data;  // little-endian value bytes
};

Entry ascii(std::uint16_t tag, const std::string& text) {
  return {tag, 2, static_cast<std::uint32_t>(text.size() + 1), text + '\0'};
}

// Degrees as one rational of micro-degrees and zero minutes and seconds.
Entry degrees(std::uint16_t tag, double deg) {
  const auto micro = static_cast<std::uint32_t>(deg * 1e6 + 0.5);
  return {tag, 5, 3,
          le(micro, 4) + le(1000000, 4) + le(0, 4) + le(1, 4) + le(0, 4) +
              le(1, 4)};
}

// Appends an IFD at the end of `tiff`, its long values after it.
void append_ifd(std::string& tiff, const std::vector<Entry>& entries) {
  std::size_t data_at = tiff.size() + 2 + 12 * entries.size() + 4;
  std::string data;
  tiff += le(static_cast<std::uint32_t>(entries.size()), 2);
  for (const auto& e : entries) {
    tiff += le(e.tag, 2) + le(e.type, 2) + le(e.count, 4);
    if (e.data.size() <= 4) {
      tiff += e.data + std::string(4 - e.data.size(), '\0');
    } else {
      tiff += le(static_cast<std::uint32_t>(data_at + data.size()), 4);
      data += e.data;
    }
  }
  tiff += le(0, 4) + data;
}

// A small real JPEG; with EXIF GPS (north, east) and a DateTimeOriginal
// ("YYYY:MM:DD HH:MM:SS") when given.
std::string photo(std::optional<std::pair<double, double>> gps = std::nullopt,
                  const std::string& taken = "") {
  std::vector<uchar> jpeg;
  cv::imencode(".jpg", cv::Mat(48, 64, CV_8UC3, cv::Scalar(40, 120, 200)),
               jpeg);
  std::string bytes(jpeg.begin(), jpeg.end());
  if (!gps && taken.empty()) return bytes;
  // IFD0 at 8 holds the two pointers: 2 + 2 * 12 + 4 bytes, so the Exif
  // IFD (one entry, 20 bytes of text) starts at 38 and the GPS IFD at 76.
  std::string tiff = std::string("II*\0", 4) + le(8, 4);
  append_ifd(tiff, {{0x8769, 4, 1, le(38, 4)}, {0x8825, 4, 1, le(76, 4)}});
  append_ifd(tiff,
             {ascii(0x9003, taken.empty() ? "2026:01:01 00:00:00" : taken)});
  if (gps)
    append_ifd(tiff, {ascii(0x0001, "N"), degrees(0x0002, gps->first),
                      ascii(0x0003, "E"), degrees(0x0004, gps->second)});
  else
    append_ifd(tiff, {});
  const std::string payload = std::string("Exif\0\0", 6) + tiff;
  std::string app1 = "\xFF\xE1";
  app1 += static_cast<char>((payload.size() + 2) >> 8);
  app1 += static_cast<char>((payload.size() + 2) & 0xff);
  return bytes.insert(2, app1 + payload);  // right after SOI
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// ---- the fixture

class ScoutClientTest : public ::testing::Test {
 protected:
  void SetUp() override {
    store_ = db::Store::open(testing::fresh_sqlite_url());
    token_ = create_token(*store_, Role::kScout, "alice");
    ServerOptions options;
    options.port = 0;
    // In front of the real upload: 503 while unavailable_ lasts. Only
    // the handler counts: the server may ask `matches` more than once.
    options.routes.push_back(ApiRoute(
        "POST /v1/captures (unavailable)",
        [this](const HttpRequest& req) {
          return req.method == "POST" && req.path == "/v1/captures" &&
                 unavailable_.load() > 0;
        },
        [this](const HttpRequest&, const Principal&) {
          --unavailable_;
          auto r =
              HttpResponse::error(status_, "unavailable", "try again later");
          if (!retry_after_.empty()) {  // instead of the server's own
            std::erase_if(r.headers, [](const auto& h) {
              return h.first == "Retry-After";
            });
            r.headers.emplace_back("Retry-After", retry_after_);
          }
          return r;
        }));
    server_ = std::make_unique<Server>(*store_, options);
    server_->start();
    dir_ = testing::make_temp_dir("scout-client");
  }

  ScoutOptions options(const std::string& token = "") {
    ScoutOptions o;
    o.client.server = "http://127.0.0.1:" + std::to_string(server_->port());
    o.client.token = token.empty() ? token_ : token;
    o.client.timeout = 10s;
    return o;
  }

  // Output to out_ and err_; waits recorded in waits_, not slept.
  ScoutHooks hooks() {
    ScoutHooks h;
    h.out = &out_;
    h.err = &err_;
    h.sleep = [this](double seconds) {
      waits_.push_back(seconds);
      return true;
    };
    return h;
  }

  std::string write(const std::string& name, const std::string& bytes) {
    const std::string path = dir_ + "/" + name;
    std::ofstream(path, std::ios::binary) << bytes;
    return path;
  }

  Json attrs(const std::string& capture_id) {
    auto doc = store_->get("/captures/" + capture_id);
    return doc ? doc->attrs : Json();
  }

  std::size_t captures() {
    db::Query all;
    all.pattern = "/captures/*";
    return store_->query(all).size();
  }

  std::atomic<int> unavailable_{0};
  int status_ = 503;
  std::string retry_after_;
  std::unique_ptr<db::Store> store_;
  std::string token_;
  std::unique_ptr<Server> server_;
  std::string dir_;
  std::ostringstream out_, err_;
  std::vector<double> waits_;
};

TEST_F(ScoutClientTest, UploadsLandUnderTheScoutScopedCaptureId) {
  auto o = options();
  o.scout_name = "field team";
  const std::vector<fs::path> photos = {
      write("b.jpg", photo({{47.07, 15.44}})),
      write("a.jpg", photo({{47.08, 15.45}}))};
  ScoutClient scout(o, hooks());
  EXPECT_EQ(scout.upload_all(
                sorted_by_file_name({photos[0].string(), photos[1].string()})),
            2u);
  EXPECT_EQ(scout.totals().succeeded, 2);
  EXPECT_EQ(scout.totals().failed, 0);
  EXPECT_EQ(scout.totals().bytes_sent,
            fs::file_size(photos[0]) + fs::file_size(photos[1]));

  // The server files "{--scout-name}.{file}" under the token's name.
  const Json a = attrs("alice.field_team.a.jpg");
  EXPECT_EQ(a.value("scout", ""), "alice");
  EXPECT_EQ(a.value("filename", ""), "a.jpg");
  EXPECT_EQ(a["gps"].value("source", ""), "exif");
  auto lines = lines_of(out_.str());
  ASSERT_EQ(lines.size(), 2u) << out_.str();
  EXPECT_EQ(
      lines[0].rfind("a.jpg  gps exif  201 alice.field_team.a.jpg seq ", 0), 0u)
      << lines[0];
  EXPECT_TRUE(contains(lines[0], " stored  ")) << lines[0];
  EXPECT_EQ(lines[1].rfind("b.jpg  gps exif  201 alice.field_team.b.jpg", 0),
            0u)
      << lines[1];
  EXPECT_EQ(waits_, std::vector<double>{0.0});  // the interval, once

  // A re-run sends the same ids: replays, nothing stored twice.
  std::ostringstream again;
  ScoutHooks h = hooks();
  h.out = &again;
  ScoutClient rerun(o, h);
  rerun.upload(photos[1]);
  EXPECT_TRUE(contains(again.str(), "201 replay alice.field_team.a.jpg"))
      << again.str();
  EXPECT_EQ(captures(), 2u);
}

TEST_F(ScoutClientTest, CaptureIdsAreStableAndBounded) {
  EXPECT_EQ(scout_capture_id("", "IMG 0001.jpg"), "IMG_0001.jpg");
  EXPECT_EQ(scout_capture_id("alice", "01.jpg"), "alice.01.jpg");
  EXPECT_EQ(scout_capture_id("a/b", "c?.png"), "a_b.c_.png");
  const std::string long_name(300, 'x');
  const std::string id = scout_capture_id("alice", long_name + ".jpg");
  EXPECT_EQ(id.size(), 128u);
  EXPECT_EQ(id, scout_capture_id("alice", long_name + ".jpg"));
  EXPECT_NE(id, scout_capture_id("alice", long_name + ".png"));
  // With --scout-name the token's name, the server keeps the id as it is.
  auto o = options();
  o.scout_name = "alice";
  ScoutClient scout(o, hooks());
  scout.upload(write("01.jpg", photo({{47.07, 15.44}})));
  EXPECT_FALSE(attrs("alice.01.jpg").is_null()) << out_.str();
}

TEST_F(ScoutClientTest, RetriesA503WithBackOffThenStores) {
  unavailable_ = 3;
  ScoutClient scout(options(), hooks());
  scout.upload(write("a.jpg", photo({{47.07, 15.44}})));
  // The server's 503 says "Retry-After: 1", longer than the first 0.5 s.
  EXPECT_EQ(waits_, (std::vector<double>{1.0, 1.0, 2.0}));
  EXPECT_EQ(scout.totals().succeeded, 1);
  EXPECT_FALSE(attrs("alice.a.jpg").is_null());
  EXPECT_TRUE(contains(out_.str(), "201 alice.a.jpg")) << out_.str();
  EXPECT_TRUE(contains(out_.str(), "(4 attempts)")) << out_.str();
  EXPECT_TRUE(contains(err_.str(),
                       "  a.jpg: unavailable: try again later; retry 1/8 in "
                       "1 s\n"))
      << err_.str();
  EXPECT_TRUE(contains(err_.str(), "retry 3/8 in 2 s")) << err_.str();
}

TEST_F(ScoutClientTest, BackOffDoublesToEightSeconds) {
  unavailable_ = 6;
  status_ = 500;  // no Retry-After
  auto o = options();
  o.retries = 6;
  ScoutClient scout(o, hooks());
  scout.upload(write("a.jpg", photo({{47.07, 15.44}})));
  EXPECT_EQ(waits_, (std::vector<double>{0.5, 1, 2, 4, 8, 8}));
  EXPECT_EQ(scout.totals().succeeded, 1);
  EXPECT_TRUE(contains(out_.str(), "(7 attempts)")) << out_.str();
  EXPECT_TRUE(contains(err_.str(), "retry 1/6 in 0.5 s\n")) << err_.str();
}

TEST_F(ScoutClientTest, RetryAfterIsHonouredAndRetriesEnd) {
  unavailable_ = 100;
  retry_after_ = "2.5";
  auto o = options();
  o.retries = 2;
  ScoutClient scout(o, hooks());
  scout.upload(write("a.jpg", photo({{47.07, 15.44}})));
  // Retry-After when longer than the back-off, the back-off otherwise.
  EXPECT_EQ(waits_, (std::vector<double>{2.5, 2.5}));
  EXPECT_EQ(scout.totals().failed, 1);
  EXPECT_EQ(captures(), 0u);
  EXPECT_TRUE(
      contains(out_.str(), "a.jpg  gps exif  503 unavailable: try again later"))
      << out_.str();
  EXPECT_TRUE(contains(out_.str(), "(3 attempts)")) << out_.str();

  HttpResult slow;
  slow.headers["retry-after"] = "600";
  EXPECT_EQ(retry_delay_s(0, &slow), 60);  // capped
  EXPECT_EQ(retry_delay_s(3, nullptr), 4);
  EXPECT_EQ(retry_delay_s(10, nullptr), 8);
  EXPECT_TRUE(is_retryable_status(429));
  EXPECT_TRUE(is_retryable_status(408));
  EXPECT_FALSE(is_retryable_status(422));
}

TEST_F(ScoutClientTest, NetworkErrorsAreRetriedAndReported) {
  auto o = options();
  server_.reset();  // nothing listens on its port any more
  o.retries = 1;
  ScoutClient scout(o, hooks());
  scout.upload(write("a.jpg", photo({{47.07, 15.44}})));
  EXPECT_EQ(waits_, std::vector<double>{0.5});
  EXPECT_EQ(scout.totals().failed, 1);
  EXPECT_TRUE(contains(out_.str(), "a.jpg  gps exif  network error: "))
      << out_.str();
  EXPECT_TRUE(contains(out_.str(), "(2 attempts)")) << out_.str();
}

TEST_F(ScoutClientTest, GpsFromTheCsvGoesBeforeTheExif) {
  auto o = options();
  o.gps_csv = write("gps.csv",
                    "image,latitude,longitude,altitude,horizontal_accuracy_m,"
                    "vertical_accuracy_m\n"
                    "a.jpg,46.5,6.5,400,2.1,3\n");
  ScoutClient scout(o, hooks());
  scout.upload_all({write("a.jpg", photo({{47.07, 15.44}})),
                    write("b.jpg", photo({{47.08, 15.45}}))});

  const Json a = attrs("alice.a.jpg");  // the CSV row, sent in the request
  EXPECT_EQ(a["gps"].value("source", ""), "request");
  EXPECT_DOUBLE_EQ(a["gps"].value("lat", 0.0), 46.5);
  EXPECT_DOUBLE_EQ(a["gps"].value("h_acc", 0.0), 2.1);
  const Json b = attrs("alice.b.jpg");  // no row: the server read the EXIF
  EXPECT_EQ(b["gps"].value("source", ""), "exif");
  EXPECT_NEAR(b["gps"].value("lat", 0.0), 47.08, 1e-9);
  auto lines = lines_of(out_.str());
  ASSERT_EQ(lines.size(), 2u) << out_.str();
  EXPECT_EQ(lines[0].rfind("a.jpg  gps csv ±2.1 m  201 alice.a.jpg", 0), 0u)
      << lines[0];
  EXPECT_EQ(lines[1].rfind("b.jpg  gps exif (no row in gps.csv)  201", 0), 0u)
      << lines[1];
}

TEST_F(ScoutClientTest, GpsFromTheTrackAtTheShiftedExifTime) {
  auto o = options();
  o.gpx = write("walk.gpx", R"(<gpx><trk><trkseg>
      <trkpt lat="47.0700" lon="15.4400"><time>2026-11-21T13:05:00Z</time>
        <hdop>1</hdop></trkpt>
      <trkpt lat="47.0710" lon="15.4410"><time>2026-11-21T13:05:10Z</time>
        <hdop>1</hdop></trkpt>
    </trkseg></trk></gpx>)");
  o.time_offset_s = 3600;  // the camera runs on CET
  ScoutClient scout(o, hooks());
  scout.upload_all({write("a.jpg", photo(std::nullopt, "2026:11:21 14:05:05")),
                    write("b.jpg", photo(std::nullopt, "2026:11:21 16:00:00")),
                    write("c.jpg", photo())});

  const Json a = attrs("alice.a.jpg");
  EXPECT_EQ(a["gps"].value("source", ""), "request");
  EXPECT_NEAR(a["gps"].value("lat", 0.0), 47.0705, 1e-9);
  EXPECT_EQ(a.value("taken", ""), "2026-11-21T13:05:05Z");
  EXPECT_EQ(attrs("alice.b.jpg").value("status", ""), "needs-gps");
  auto lines = lines_of(out_.str());
  ASSERT_EQ(lines.size(), 3u) << out_.str();
  EXPECT_EQ(lines[0].rfind("a.jpg  gps gpx ±5.0 m  201", 0), 0u) << lines[0];
  EXPECT_TRUE(contains(lines[1],
                       "gps none (taken 2026-11-21T15:00:00Z, off the track)"))
      << lines[1];
  EXPECT_TRUE(contains(lines[2], "(no EXIF DateTimeOriginal to match"))
      << lines[2];
}

TEST_F(ScoutClientTest, BadFilesAreReportedAndSkipped) {
  const std::string missing = dir_ + "/missing.jpg";
  ScoutClient scout(options(), hooks());
  EXPECT_EQ(scout.upload_all({write("notes.txt", "a note"), missing,
                              write("broken.jpg", "not a JPEG at all"),
                              write("good.jpg", photo({{47.07, 15.44}}))}),
            4u);
  EXPECT_EQ(scout.totals().succeeded, 1);
  EXPECT_EQ(scout.totals().failed, 3);
  auto lines = lines_of(out_.str());
  ASSERT_EQ(lines.size(), 4u) << out_.str();
  EXPECT_EQ(lines[0], "notes.txt  not a .jpg/.jpeg/.png file");
  EXPECT_EQ(lines[1], "missing.jpg  cannot read " + missing);
  EXPECT_EQ(lines[2].rfind("broken.jpg  gps none  422 unprocessable: ", 0), 0u)
      << lines[2];
  EXPECT_EQ(lines[3].rfind("good.jpg  gps exif  201 alice.good.jpg", 0), 0u)
      << lines[3];
  EXPECT_EQ(captures(), 1u);
  EXPECT_EQ(scout_summary(scout.totals(), 0),
            "1 of 4 photos uploaded (" +
                std::to_string(scout.totals().bytes_sent) + " B), 3 failed");
}

TEST_F(ScoutClientTest, ARefusedTokenStopsTheRun) {
  ScoutClient scout(options("not-a-token"), hooks());
  EXPECT_EQ(scout.upload_all({write("a.jpg", photo({{47.07, 15.44}})),
                              write("b.jpg", photo({{47.07, 15.44}}))}),
            1u);
  EXPECT_TRUE(scout.totals().refused);
  EXPECT_TRUE(waits_.empty());  // a 401 is not retried
  EXPECT_TRUE(contains(out_.str(), "401 unauthorized: ")) << out_.str();
  EXPECT_EQ(scout_summary(scout.totals(), 1),
            "0 of 1 photos uploaded (0 B), 1 failed, token refused before 1 "
            "more");
}

TEST_F(ScoutClientTest, WatchSendsNewPhotosOnceTheyAreStable) {
  const std::string folder = dir_ + "/photos";
  fs::create_directories(folder);
  std::ofstream(folder + "/a.jpg", std::ios::binary) << photo({{47.07, 15.44}});
  std::ofstream(folder + "/.hidden.jpg", std::ios::binary) << "metadata";
  auto o = options();
  o.watch_poll_s = 0.25;
  ScoutHooks h = hooks();
  int polls = 0;
  h.sleep = [&](double seconds) {
    if (seconds != 0.25) return true;  // the interval between photos
    if (++polls == 2)                  // a photo arrives while watching
      std::ofstream(folder + "/b.jpg", std::ios::binary)
          << photo({{47.08, 15.45}});
    return polls < 5;  // then a stop
  };
  ScoutClient scout(o, h);
  scout.upload_all(list_photos(folder, err_));
  scout.watch(folder);
  EXPECT_EQ(polls, 5);
  EXPECT_EQ(scout.totals().succeeded, 2);  // a.jpg not again, b.jpg once
  EXPECT_EQ(captures(), 2u);
  EXPECT_FALSE(attrs("alice.b.jpg").is_null()) << out_.str();
  EXPECT_TRUE(contains(err_.str(), "watching " + folder)) << err_.str();
}

TEST(ScoutPhotos, ListsPhotosInFileNameOrder) {
  const std::string dir = testing::make_temp_dir("scout-photos");
  for (const char* name :
       {"b.JPG", "a.png", "c.jpeg", "._a.jpg", "notes.txt", "d.tif"})
    std::ofstream(dir + "/" + name) << "x";
  fs::create_directory(dir + "/e.jpg");  // a folder, not a photo
  std::ostringstream err;
  std::vector<std::string> names;
  for (const auto& p : list_photos(dir, err))
    names.push_back(p.filename().string());
  EXPECT_EQ(names, (std::vector<std::string>{"a.png", "b.JPG", "c.jpeg"}));
  EXPECT_TRUE(err.str().empty());
  EXPECT_TRUE(list_photos(dir + "/absent", err).empty());
  EXPECT_TRUE(contains(err.str(), "cannot list " + dir + "/absent"));
}

}  // namespace
}  // namespace arscout::scout
