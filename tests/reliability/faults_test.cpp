// Faults under a running `arscout serve`:
// - its PostgreSQL server stopped for seconds, then `pg_ctl restart`ed, while
//   four `arscout scout` processes upload: the server answers 503 while the
//   database is down (WebSocket upgrades too), the scouts retry, and every
//   photo is stored once;
// - its SQLite file on a disk that fills up: uploads get a clear 503, reads
//   go on, nothing acknowledged is lost, the file passes PRAGMA
//   integrity_check, and uploads succeed again once there is space;
// - its SQLite file on a disk that has turned read-only: between two runs
//   of the server, a clear start error; under the running server (an ext4
//   disk failing, errors=remount-ro), a 503 that says so; either way the
//   data intact once the disk is writable again.
// The engine killed mid-increment is tests/service/kill_test.cpp.
#include <sqlite3.h>

#include <cerrno>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <thread>

#include <gtest/gtest.h>

#include "arscout/db/store.h"
#include "arscout/http/change_stream.h"
#include "arscout/http/client.h"
#include "arscout/ingest/auth.h"
#include "flaky_upload.h"
#include "raw_http.h"
#include "scratch_disks.h"
#include "serve_process.h"
#include "test_stores.h"

namespace arscout {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;
using namespace std::chrono_literals;

std::string metadata(const std::string& id) {
  return Json{{"capture_id", id},
              {"gps", {{"lat", 47.07}, {"lon", 15.44}, {"h_acc", 3.0}}}}
      .dump();
}

http::HttpResult upload(http::Client& client, const std::string& id,
                        const std::string& jpeg) {
  return client.request(
      "POST", "/v1/captures", jpeg,
      {{"Content-Type", "image/jpeg"}, {"X-Capture-Metadata", metadata(id)}});
}

http::Client client_for(const testing::ServeProcess& server,
                        const std::string& token) {
  http::ClientOptions options;
  options.server = server.url();
  options.token = token;
  options.timeout = 30s;
  return http::Client(options);
}

// ---- PostgreSQL restarted under the server ----

// A PostgreSQL server of this test's own, which it may stop and restart:
// the fixture's server is shared with tests running in parallel.
class PrivatePostgres {
 public:
  PrivatePostgres() : state_(testing::make_temp_dir("pgfault")) {
    run("start");
    std::ifstream in(state_ + "/url");
    in >> url_;
  }
  ~PrivatePostgres() { run("stop"); }
  bool run(const std::string& command) {
    std::string line = std::string(ARSCOUT_PG_FIXTURE) + " " + command + " " +
                       state_ + " >> " + state_ + ".log 2>&1";
    return std::system(line.c_str()) == 0;
  }
  const std::string& url() const { return url_; }

 private:
  std::string state_, url_;
};

// Photos on disk with a gps.csv, as a scout's phone holds them.
std::string write_photo_folder(const std::string& dir, int scout, int count) {
  fs::create_directories(dir);
  std::ofstream csv(dir + "/gps.csv");
  csv << "image,latitude,longitude,altitude,horizontal_accuracy_m,"
         "vertical_accuracy_m\n";
  for (int i = 0; i < count; ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "%04d.jpg", i);
    std::ofstream(dir + "/" + name, std::ios::binary)
        << testing::noise_jpeg(scout * 1000 + i, 320, 240);
    csv << name << "," << 47.07 + 0.001 * scout << "," << 15.44 + 1e-5 * i
        << ",350.0,3.0,5.0\n";
  }
  return dir + "/gps.csv";
}

// Polls until the server answers `status` to GET /healthz (or times out).
bool wait_for_health(const testing::ServeProcess& server, int status,
                     std::chrono::seconds timeout) {
  auto client = client_for(server, "");
  auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    try {
      if (client.get("/healthz").status == status) return true;
    } catch (const http::NetworkError&) {
    }
    std::this_thread::sleep_for(100ms);
  }
  return false;
}

TEST(PostgresRestart, ServerAnswers503WhileDownAndScoutsLoseNothing) {
  if (!fs::exists("/usr/lib/postgresql/15/bin/pg_ctl")) {
    if (testing::in_ci()) FAIL() << "PostgreSQL 15 is not installed";
    GTEST_SKIP() << "PostgreSQL 15 is not installed";
  }
  PrivatePostgres pg;
  ASSERT_FALSE(pg.url().empty()) << "the private PostgreSQL did not start";
  const std::string dir = testing::make_temp_dir("pgrestart");
  auto store = db::Store::open(pg.url());
  constexpr int kScouts = 4, kPhotos = 24;
  std::vector<std::string> tokens;
  for (int s = 0; s < kScouts; ++s)
    tokens.push_back(ingest::create_token(*store, ingest::Role::kScout,
                                          "s" + std::to_string(s)));
  std::string tester = ingest::create_token(*store, ingest::Role::kScout, "t");
  testing::ServeProcess server(ARSCOUT_CLI, pg.url(), dir + "/serve.log");

  std::vector<std::unique_ptr<testing::ToolProcess>> scouts;
  for (int s = 0; s < kScouts; ++s) {
    std::string photos = dir + "/s" + std::to_string(s);
    std::string csv = write_photo_folder(photos, s, kPhotos);
    scouts.push_back(std::make_unique<testing::ToolProcess>(
        ARSCOUT_CLI,
        std::vector<std::string>{"scout", "--server", server.url(), "--token",
                                 tokens[s], "--scout-name",
                                 "s" + std::to_string(s), "--dir", photos,
                                 "--gps-csv", csv, "--interval", "0.25",
                                 "--retries", "12", "--timeout", "20"},
        photos + ".log"));
  }

  // Down for a few seconds mid-session: a clear 503, nothing stored.
  std::this_thread::sleep_for(1500ms);
  const std::int64_t seq_before = store->last_seq();
  ASSERT_TRUE(pg.run("down"));
  EXPECT_TRUE(wait_for_health(server, 503, 10s));
  auto client = client_for(server, tester);
  const std::string mine = testing::noise_jpeg(424242, 320, 240);
  http::HttpResult refused = upload(client, "t-during-outage", mine);
  EXPECT_EQ(refused.status, 503) << refused.body;
  EXPECT_EQ(refused.json().value("error", ""), "unavailable") << refused.body;
  EXPECT_EQ(refused.headers["retry-after"], "1");
  // WebSockets opened while the database is down (hostile clients round
  // two, row 3): the upgrade looked the token up on a network thread with
  // no handler, and the store's exception ended the server. Each is now a
  // 503, and the server lives on.
  const std::string upgrade =
      "GET /v1/subscribe?since=0 HTTP/1.1\r\nHost: a\r\nUpgrade: "
      "websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Key: "
      "dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n"
      "Authorization: Bearer " +
      tester + "\r\n\r\n";
  for (int i = 0; i < 8; ++i) {
    const std::string reply =
        testing::raw_exchange(testing::port_of(server.url()), upgrade);
    EXPECT_EQ(reply.rfind("HTTP/1.1 503", 0), 0u) << reply;
  }
  EXPECT_TRUE(server.process().running()) << "the server ended";
  std::this_thread::sleep_for(3s);
  ASSERT_TRUE(pg.run("up"));
  EXPECT_TRUE(wait_for_health(server, 200, 30s)) << "no recovery";
  {
    http::ChangeStream stream({server.url(), tester}, 0);
    EXPECT_TRUE(stream.next(10s)) << "no change through a stream after it";
  }
  EXPECT_GT(store->last_seq(), seq_before - 1);

  // Then a plain `pg_ctl restart` while the scouts are still at it.
  std::this_thread::sleep_for(1s);
  ASSERT_TRUE(pg.run("restart"));
  int retries = 0;
  for (int s = 0; s < kScouts; ++s) {
    auto status = scouts[s]->wait_for(240s);
    ASSERT_TRUE(status) << "scout " << s << " still running";
    std::string log = testing::slurp(dir + "/s" + std::to_string(s) + ".log");
    EXPECT_EQ(testing::describe_status(*status), "exit 0") << log;
    for (std::size_t at = 0; (at = log.find("; retry ", at)) != log.npos; ++at)
      ++retries;
  }
  std::cout << "PostgreSQL down 3 s and restarted: " << kScouts << " scouts x "
            << kPhotos << " photos, " << retries << " retries\n";
  http::HttpResult retried = upload(client, "t-during-outage", mine);
  EXPECT_EQ(retried.status, 201) << retried.body;

  db::Query all;
  all.pattern = "/captures/*";
  EXPECT_EQ(store->query(all).size(), std::size_t{kScouts * kPhotos + 1});
  EXPECT_EQ(store->changes(0, "/captures/*", 100000).size(),
            std::size_t{kScouts * kPhotos + 1});
  for (int s = 0; s < kScouts; ++s)
    for (int i = 0; i < kPhotos; ++i) {
      char id[32];
      std::snprintf(id, sizeof id, "s%d.%04d.jpg", s, i);
      auto doc = store->get(std::string("/captures/") + id);
      ASSERT_TRUE(doc) << id << " lost";
      EXPECT_EQ(store->get_blob(doc->blobs.at("image")),
                testing::noise_jpeg(s * 1000 + i, 320, 240))
          << id;
    }
  EXPECT_TRUE(server.process().running()) << testing::slurp(dir + "/serve.log");
}

// ---- SQLite on a disk that fills up or turns read-only ----

#define ARSCOUT_DISK_OR_SKIP(disk) \
  if (!(disk).mounted()) GTEST_SKIP() << (disk).error()

std::string integrity_check(const std::string& file) {
  sqlite3* db = nullptr;
  std::string result = "cannot open";
  if (sqlite3_open_v2(file.c_str(), &db, SQLITE_OPEN_READONLY, nullptr) ==
      SQLITE_OK) {
    sqlite3_stmt* st = nullptr;
    result.clear();
    sqlite3_prepare_v2(db, "PRAGMA integrity_check", -1, &st, nullptr);
    while (st != nullptr && sqlite3_step(st) == SQLITE_ROW)
      result += reinterpret_cast<const char*>(sqlite3_column_text(st, 0));
    sqlite3_finalize(st);
  }
  sqlite3_close(db);
  return result;
}

class SqliteDisk : public ::testing::Test {
 protected:
  // A store in `dir` with a scout token, served by `arscout serve`.
  void serve_on(const std::string& dir) {
    file_ = dir + "/arscout.db";
    token_ = ingest::create_token(*db::Store::open("sqlite:" + file_),
                                  ingest::Role::kScout, "alice");
    log_ = testing::make_temp_dir("sqlitedisk") + "/serve.log";
    server_ = std::make_unique<testing::ServeProcess>(ARSCOUT_CLI,
                                                      "sqlite:" + file_, log_);
  }

  std::string photo(int i) { return testing::noise_jpeg(i, 480, 360); }
  // Ids in alice's own space ("alice.N"), kept as they are by the server.
  std::string id(int i) { return "alice." + std::to_string(i); }

  void stop_server() {
    server_->process().signal(SIGTERM);
    ASSERT_TRUE(server_->process().wait_for(30s)) << "serve did not stop";
  }

  // Uploads photos first..first+count-1, each acknowledged, into stored_.
  void upload_acknowledged(int first, int count) {
    auto client = client_for(*server_, token_);
    for (int i = first; i < first + count; ++i) {
      ASSERT_EQ(upload(client, id(i), photo(i)).status, 201);
      stored_.push_back(i);
    }
  }

  // Once the disk is writable again: a new server accepts upload `next`,
  // and after it stops, nothing is missing.
  void serve_again_and_expect_intact(int next) {
    server_ = std::make_unique<testing::ServeProcess>(
        ARSCOUT_CLI, "sqlite:" + file_, log_ + ".2");
    upload_acknowledged(next, 1);
    stop_server();
    expect_intact(stored_);
  }

  // With the server stopped: the file is sound and holds exactly `stored`.
  void expect_intact(const std::vector<int>& stored) {
    EXPECT_EQ(integrity_check(file_), "ok");
    auto store = db::Store::open("sqlite:" + file_);
    db::Query all;
    all.pattern = "/captures/*";
    EXPECT_EQ(store->query(all).size(), stored.size());
    for (int i : stored) {
      auto doc = store->get("/captures/" + id(i));
      ASSERT_TRUE(doc) << id(i) << " was acknowledged but is lost";
      EXPECT_EQ(store->get_blob(doc->blobs.at("image")), photo(i)) << id(i);
    }
  }

  std::string file_, token_, log_;
  std::unique_ptr<testing::ServeProcess> server_;
  std::vector<int> stored_;
};

TEST_F(SqliteDisk, FullDiskGivesA503AndLosesNothing) {
  testing::Tmpfs disk("3m");
  ARSCOUT_DISK_OR_SKIP(disk);
  serve_on(disk.dir());
  auto client = client_for(*server_, token_);
  http::HttpResult refused;
  int next = 0;
  for (; next < 200; ++next) {
    refused = upload(client, id(next), photo(next));
    if (refused.status != 201) break;
    stored_.push_back(next);
  }
  ASSERT_GT(stored_.size(), 2u) << "the disk filled before any upload";
  ASSERT_EQ(refused.status, 503) << refused.body;
  EXPECT_EQ(refused.json().value("error", ""), "unavailable");
  EXPECT_NE(refused.body.find("full"), std::string::npos) << refused.body;
  std::cout << "full disk, after " << stored_.size()
            << " uploads: " << refused.body << "\n";
  // Reads go on from a full disk.
  EXPECT_EQ(client.get("/v1/docs/captures/" + id(stored_.front())).status, 200);
  EXPECT_EQ(client.get("/healthz").status, 200);
  EXPECT_EQ(upload(client, id(next), photo(next)).status, 503);

  ASSERT_TRUE(disk.remount("64m", false));  // space freed
  http::HttpResult retried = upload(client, id(next), photo(next));
  EXPECT_EQ(retried.status, 201) << retried.body;
  if (retried.status == 201) stored_.push_back(next);
  stop_server();
  expect_intact(stored_);
}

// Linux refuses to make a file system read-only while a process has files
// on it open for writing, so the disk turns read-only between two runs of
// the server: the second refuses to start, clearly, and the data survives.
TEST_F(SqliteDisk, ReadOnlyDiskIsAClearStartErrorAndLosesNothing) {
  testing::Tmpfs disk("64m");
  ARSCOUT_DISK_OR_SKIP(disk);
  serve_on(disk.dir());
  upload_acknowledged(0, 4);
  stop_server();
  ASSERT_TRUE(disk.remount("64m", true)) << std::strerror(errno);

  const std::string log = testing::make_temp_dir("rostart") + "/serve.log";
  testing::ToolProcess refused(ARSCOUT_CLI,
                               {"serve", "--db", "sqlite:" + file_, "--listen",
                                "127.0.0.1:0", "--web-root", ""},
                               log);
  auto status = refused.wait_for(30s);
  ASSERT_TRUE(status) << "serve runs on a read-only store:\n"
                      << testing::slurp(log);
  EXPECT_NE(testing::describe_status(*status), "exit 0");
  EXPECT_NE(testing::slurp(log).find("read-only file system"),
            std::string::npos)
      << testing::slurp(log);
  std::cout << "read-only start: " << testing::slurp(log);

  ASSERT_TRUE(disk.remount("64m", false));
  serve_again_and_expect_intact(4);
}

// The disk fails under the running server and the kernel turns it
// read-only (ext4, errors=remount-ro), as happens in the field: uploads get
// a 503 that says so, reads go on, and after the operator's e2fsck and
// remount nothing acknowledged is lost.
TEST_F(SqliteDisk, DiskTurningReadOnlyUnderTheServerGives503AndLosesNothing) {
  testing::Ext4Disk disk("64M");
  ARSCOUT_DISK_OR_SKIP(disk);
  serve_on(disk.dir());
  upload_acknowledged(0, 6);
  ASSERT_TRUE(disk.fail()) << disk.error();

  auto client = client_for(*server_, token_);
  const http::HttpResult refused = upload(client, id(6), photo(6));
  std::cout << "disk turned read-only: " << refused.body << "\n";
  EXPECT_EQ(refused.status, 503) << refused.body;
  EXPECT_EQ(refused.json().value("error", ""), "unavailable");
  EXPECT_NE(refused.body.find("read-only"), std::string::npos) << refused.body;
  EXPECT_EQ(client.get("/v1/docs/captures/" + id(0)).status, 200);
  EXPECT_EQ(client.get("/healthz").status, 200);
  stop_server();

  ASSERT_TRUE(disk.repair()) << disk.error();
  expect_intact(stored_);
  serve_again_and_expect_intact(6);
}

}  // namespace
}  // namespace arscout
