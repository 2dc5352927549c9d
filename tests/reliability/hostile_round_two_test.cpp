// Hostile clients, round two (docs/RELIABILITY.md): what an outside probe
// sent to `arscout serve`, against the server in its own process so that
// its memory and its /healthz can be watched. Each case failed before its
// fix. The rules without sockets (the JSON parser, the rates, the static
// files) are in tests/ingest/limits_test.cpp, session replay in
// tests/ingest/session_test.cpp, WebSockets during a PostgreSQL outage in
// faults_test.cpp.
//
// TheServerStaysUpUnderEveryAttackAtOnce runs rows 1, 2, 4, 5 and 6 at once,
// ARSCOUT_ATTACKS clients each (4 here; 32 for the acceptance figures:
// `ctest -L long -R hostile`, docs/RELIABILITY.md).
#include <arpa/inet.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdlib>
#include <iostream>
#include <map>
#include <mutex>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "arscout/db/store.h"
#include "arscout/http/client.h"
#include "arscout/ingest/auth.h"
#include "arscout/util/process.h"
#include "flaky_upload.h"
#include "raw_http.h"
#include "sanitized.h"
#include "serve_process.h"
#include "synthetic_street.h"
#include "test_stores.h"

namespace arscout {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

using testing::kSanitized;

// ---- the attacks, one client each -----------------------------------------

std::string multipart_upload(const std::string& token,
                             const std::string& metadata,
                             const std::string& image) {
  const std::string boundary = "hostile-boundary-7f3a";
  const std::string body =
      "--" + boundary +
      "\r\nContent-Disposition: form-data; name=\"metadata\"\r\n\r\n" +
      metadata + "\r\n--" + boundary +
      "\r\nContent-Disposition: form-data; name=\"image\"; "
      "filename=\"a.jpg\"\r\nContent-Type: image/jpeg\r\n\r\n" +
      image + "\r\n--" + boundary + "--\r\n";
  return "POST /v1/captures HTTP/1.1\r\nHost: a\r\nAuthorization: Bearer " +
         token + "\r\nContent-Type: multipart/form-data; boundary=" + boundary +
         "\r\nContent-Length: " + std::to_string(body.size()) +
         "\r\nConnection: close\r\n\r\n" + body;
}

// Row 1: a metadata part of empty objects, parsed in quadratic time.
std::string empty_objects(std::size_t bytes) {
  std::string text = "{\"a\":[{}";
  while (text.size() + 4 < bytes) text += ",{}";
  return text + "]}";
}

// Row 2: a metadata part of zeros, each a JSON value of its own.
std::string zeros(std::size_t bytes) {
  std::string text = "{\"a\":[0";
  text.reserve(bytes + 4);
  while (text.size() + 4 < bytes) text += ",0";
  return text + "]}";
}

int status_of(const std::string& reply) {
  if (reply.rfind("HTTP/1.1 ", 0) != 0) return 0;
  return std::atoi(reply.c_str() + 9);
}

// Row 4: GET of a large blob by a client that never reads (a small receive
// buffer, held open for `hold`).
void never_read(std::uint16_t port, const std::string& token,
                const std::string& hash, std::chrono::milliseconds hold) {
  const int fd = testing::connect_local(port);
  if (fd < 0) return;
  const int small = 4096;
  setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &small, sizeof small);
  const std::string request = "GET /v1/blobs/" + hash +
                              " HTTP/1.1\r\nHost: a\r\nAuthorization: Bearer " +
                              token + "\r\n\r\n";
  send(fd, request.data(), request.size(), MSG_NOSIGNAL);
  std::this_thread::sleep_for(hold);
  close(fd);
}

// Row 6: a WebSocket stream whose client sends one frame that says it is
// 16,000,000 bytes long and then sends it. Returns the bytes the server
// took before it closed the stream.
std::uint64_t huge_frame(std::uint16_t port, const std::string& token) {
  const int fd = testing::connect_local(port);
  if (fd < 0) return 0;
  const std::string upgrade =
      "GET /v1/subscribe?since=0 HTTP/1.1\r\nHost: a\r\nUpgrade: websocket\r\n"
      "Connection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n"
      "Sec-WebSocket-Version: 13\r\nAuthorization: Bearer " +
      token + "\r\n\r\n";
  send(fd, upgrade.data(), upgrade.size(), MSG_NOSIGNAL);
  std::string head;
  char c;
  while (head.find("\r\n\r\n") == std::string::npos && recv(fd, &c, 1, 0) == 1)
    head.push_back(c);
  std::uint64_t sent = 0;
  if (head.rfind("HTTP/1.1 101", 0) == 0) {
    constexpr std::uint64_t kLength = 16000000;
    std::string frame = {'\x82', '\xFF'};  // binary, masked, 64-bit length
    for (int shift = 56; shift >= 0; shift -= 8)
      frame.push_back(static_cast<char>((kLength >> shift) & 0xFF));
    frame += std::string(4, '\0');  // the mask: the payload goes as sent
    send(fd, frame.data(), frame.size(), MSG_NOSIGNAL);
    const std::string piece(256 * 1024, '\0');
    timeval quick{2, 0};
    setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &quick, sizeof quick);
    while (sent < kLength) {
      const ssize_t n = send(fd, piece.data(), piece.size(), MSG_NOSIGNAL);
      if (n <= 0) break;
      sent += static_cast<std::uint64_t>(n);
    }
  }
  close(fd);
  return sent;
}

// The slowest /healthz while `busy` holds, sampled every 50 ms on fresh
// connections.
class HealthWatch {
 public:
  explicit HealthWatch(std::uint16_t port)
      : thread_([this, port] {
          while (!stop_) {
            const auto t0 = Clock::now();
            const std::string reply =
                testing::raw_exchange(port,
                                      "GET /healthz HTTP/1.1\r\nHost: "
                                      "a\r\nConnection: close\r\n\r\n");
            const double ms =
                std::chrono::duration<double, std::milli>(Clock::now() - t0)
                    .count();
            std::lock_guard lock(mutex_);
            if (ms > slowest_ms_)
              slowest_at_s_ =
                  std::chrono::duration<double>(t0 - started_).count();
            slowest_ms_ = std::max(slowest_ms_, ms);
            all_ms_.push_back(ms);
            if (std::chrono::duration<double>(t0 - started_).count() > 1.0)
              slowest_after_1s_ = std::max(slowest_after_1s_, ms);
            if (status_of(reply) != 200) ++failures_;
            ++samples_;
            std::this_thread::sleep_for(50ms);
          }
        }) {}
  ~HealthWatch() { stop(); }
  void stop() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
  }
  double slowest_ms() {
    std::lock_guard lock(mutex_);
    return slowest_ms_;
  }
  int failures() {
    std::lock_guard lock(mutex_);
    return failures_;
  }
  int samples() {
    std::lock_guard lock(mutex_);
    return samples_;
  }
  // "p50 A ms, p95 B ms, slowest C ms at D s".
  std::string summary() {
    std::lock_guard lock(mutex_);
    std::vector<double> sorted = all_ms_;
    std::sort(sorted.begin(), sorted.end());
    const auto at = [&](double q) {
      return sorted.empty() ? 0.0
                            : sorted[static_cast<std::size_t>(
                                  q * static_cast<double>(sorted.size() - 1))];
    };
    return "p50 " + std::to_string(at(0.5)) + " ms, p95 " +
           std::to_string(at(0.95)) + " ms, slowest " +
           std::to_string(slowest_ms_) + " ms at " +
           std::to_string(slowest_at_s_) + " s, slowest after the first " +
           "second " + std::to_string(slowest_after_1s_) + " ms";
  }

 private:
  std::atomic<bool> stop_{false};
  std::mutex mutex_;
  const Clock::time_point started_ = Clock::now();
  std::vector<double> all_ms_;
  double slowest_at_s_ = 0;
  double slowest_after_1s_ = 0;
  double slowest_ms_ = 0;
  int failures_ = 0, samples_ = 0;
  std::thread thread_;
};

class HostileRoundTwo : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing::make_temp_dir("hostile2");
    url_ = testing::fresh_sqlite_url();
    store_ = db::Store::open(url_);
    scout_ = ingest::create_token(*store_, ingest::Role::kScout, "sam");
    planner_ = ingest::create_token(*store_, ingest::Role::kPlanner, "pat");
  }
  std::unique_ptr<testing::ServeProcess> serve(
      const std::string& name, std::vector<std::string> extra = {}) {
    return std::make_unique<testing::ServeProcess>(
        ARSCOUT_CLI, url_, dir_ + "/" + name + ".log", extra);
  }

  std::string dir_, url_, scout_, planner_;
  std::unique_ptr<db::Store> store_;
};

// Rows 1 and 2: a metadata part of 300 KB of empty objects took seconds of
// a core each (32 at once: /healthz silent for a minute), and one of 60 MB
// of zeros took 1.5 GB. The part is now at most 64 KiB (413 beyond) and
// parsed in linear time, and a token has at most 2 bodies read at once
// (429 beyond, from the header), so a crowd of them holds 2 bodies.
TEST_F(HostileRoundTwo, MetadataPartsAreBoundedAndParsedInLinearTime) {
  auto server = serve("metadata");
  const std::uint16_t port = testing::port_of(server->url());
  const std::string image = testing::noise_jpeg(1, 64, 48);
  for (const std::string& metadata :
       {empty_objects(300 << 10), zeros(20 << 20)}) {
    const std::string reply =
        testing::raw_exchange(port, multipart_upload(scout_, metadata, image));
    EXPECT_EQ(status_of(reply), 413) << reply.substr(0, 300);
  }
  const std::int64_t before_kib = server->rss_kib();
  std::vector<int> statuses(8, 0);
  std::vector<std::thread> clients;
  const auto t0 = Clock::now();
  for (int i = 0; i < 8; ++i)
    clients.emplace_back([&, i] {
      statuses[i] = status_of(testing::raw_exchange(
          port, multipart_upload(
                    scout_, i % 2 ? empty_objects(300 << 10) : zeros(20 << 20),
                    image)));
    });
  for (std::thread& t : clients) t.join();
  const double seconds =
      std::chrono::duration<double>(Clock::now() - t0).count();
  const double grown_mb = (server->peak_rss_kib() - before_kib) / 1024.0;
  std::cout << "8 oversized metadata parts (4 x 300 KB of {}, 4 x 20 MB of "
               "0): "
            << seconds << " s, peak RSS +" << grown_mb << " MB" << std::endl;
  for (int s : statuses) EXPECT_TRUE(s == 413 || s == 429) << s;
  // The bodies themselves are held while they are read: 2 at a time.
  EXPECT_LT(grown_mb, kSanitized ? 300 : 100);
  // Within the bound a part of 20,000 empty objects is read at once.
  const auto t1 = Clock::now();
  const std::string reply = testing::raw_exchange(
      port,
      multipart_upload(
          scout_, R"({"capture_id":"c1","extra":)" + empty_objects(60000) + "}",
          image));
  EXPECT_EQ(status_of(reply), 201) << reply;
  EXPECT_LT(Clock::now() - t1, 5s);
}

// Row 4: 150 GETs of a 51.6 MB blob from clients that never read took
// +7.5 GB until their write timeout, and /healthz waited 50 s. A blob is
// now sent in 256 KiB pieces read as the client takes them, under one
// budget for the whole server.
TEST_F(HostileRoundTwo, BlobsAreSentAsTheClientReadsThem) {
  std::string bytes(24 << 20, '\0');
  for (std::size_t i = 0; i < bytes.size(); ++i)
    bytes[i] = static_cast<char>((i * 2654435761u) >> 13);
  const std::string hash = store_->put_blob(bytes);
  auto server = serve("blobs");
  const std::uint16_t port = testing::port_of(server->url());
  // Whole, and a range, as they were stored.
  http::Client planner({server->url(), planner_});
  const auto whole = planner.get("/v1/blobs/" + hash);
  ASSERT_EQ(whole.status, 200);
  EXPECT_TRUE(whole.body == bytes);
  const auto part = planner.request("GET", "/v1/blobs/" + hash, "",
                                    {{"Range", "bytes=1000000-1300099"}});
  ASSERT_EQ(part.status, 206);
  EXPECT_TRUE(part.body == bytes.substr(1000000, 300100));

  const std::int64_t before_kib = server->rss_kib();
  HealthWatch health(port);
  std::vector<std::thread> clients;
  for (int i = 0; i < 40; ++i)
    clients.emplace_back([&] { never_read(port, planner_, hash, 4s); });
  for (std::thread& t : clients) t.join();
  health.stop();
  const double grown_mb = (server->peak_rss_kib() - before_kib) / 1024.0;
  std::cout << "40 readers that never read a 24 MiB blob: peak RSS +"
            << grown_mb << " MB, /healthz " << health.summary() << " ("
            << health.samples() << " samples)" << std::endl;
  // Whole bodies were 40 x 24 MiB; AddressSanitizer's quarantine keeps up
  // to 256 MB of freed pieces.
  EXPECT_LT(grown_mb, kSanitized ? 500 : 150);
  // Answered throughout; how fast is the long run's figure (below), not a
  // time this suite asserts beside other tests.
  EXPECT_EQ(health.failures(), 0);
}

// Row 6: 100 streams each sending one frame of 16,000,000 bytes held
// +1.5 GB (Beast's default message limit is 16 MiB, and the buffer kept its
// capacity). A subscriber's frame is now refused past 4 KiB, from its
// header.
TEST_F(HostileRoundTwo, AStreamReadsNoLargeFrame) {
  auto server = serve("frames", {"--max-streams-per-token", "200"});
  const std::uint16_t port = testing::port_of(server->url());
  const std::int64_t before_kib = server->rss_kib();
  std::vector<std::uint64_t> taken(12, 0);
  std::vector<std::thread> clients;
  for (std::size_t i = 0; i < taken.size(); ++i)
    clients.emplace_back([&, i] { taken[i] = huge_frame(port, planner_); });
  for (std::thread& t : clients) t.join();
  const double grown_mb = (server->peak_rss_kib() - before_kib) / 1024.0;
  std::uint64_t most = 0;
  for (std::uint64_t t : taken) most = std::max(most, t);
  std::cout << "12 streams sending 16 MB frames: the server took at most "
            << most / 1e6 << " MB of one, peak RSS +" << grown_mb << " MB"
            << std::endl;
  EXPECT_LT(most, 16000000u) << "a whole 16 MB frame was taken";
  EXPECT_LT(grown_mb, 64);
  http::Client probe({server->url(), ""});
  EXPECT_EQ(probe.get("/healthz").status, 200);
}

// Row 11: GET /v1/subscribe?access_token=T wrote the whole token into the
// info access log. Row 16: HEAD /v1/docs/... was 405 although the route
// lists HEAD. Row 12: no security headers on the pages. Row 10: "GET //"
// and the web folder's absolute path was a 301 to "//" and that folder.
TEST_F(HostileRoundTwo, LogsHeadersHeadAndRedirects) {
  const std::string web = std::string(ARSCOUT_SOURCE_DIR) + "/viewer/web";
  auto server = serve("log", {"--log-level", "info", "--web-root", web});
  const std::uint16_t port = testing::port_of(server->url());
  http::Client planner({server->url(), planner_});
  EXPECT_EQ(planner.get("/v1/subscribe?access_token=" + planner_).status, 400);
  EXPECT_EQ(planner.get("/v1/subscribe?access%5Ftoken=" + planner_).status,
            400);
  store_->put("/notes/n1", "note", db::Json{{"text", std::string(300, 'x')}});
  const auto got = planner.get("/v1/docs/notes/n1");
  const std::string head = testing::raw_exchange(
      port,
      "HEAD /v1/docs/notes/n1 HTTP/1.1\r\nHost: a\r\nAuthorization: "
      "Bearer " +
          planner_ + "\r\nConnection: close\r\n\r\n");
  EXPECT_EQ(status_of(head), 200) << head;
  EXPECT_NE(head.find("Content-Length: " + std::to_string(got.body.size())),
            std::string::npos)
      << head;
  EXPECT_EQ(head.substr(head.find("\r\n\r\n") + 4), "") << "a body to HEAD";

  const std::string page = testing::raw_exchange(
      port, "GET /scout/ HTTP/1.1\r\nHost: a\r\nConnection: close\r\n\r\n");
  EXPECT_EQ(status_of(page), 200);
  for (const char* header :
       {"Content-Security-Policy: default-src 'self'",
        "X-Content-Type-Options: nosniff", "X-Frame-Options: DENY"})
    EXPECT_NE(page.find(header), std::string::npos) << header;
  const std::string escape =
      testing::raw_exchange(port, "GET /" + web +
                                      "/scout HTTP/1.1\r\nHost: a\r\n"
                                      "Connection: close\r\n\r\n");
  EXPECT_EQ(status_of(escape), 404) << escape.substr(0, 200);
  EXPECT_EQ(escape.find("Location: //"), std::string::npos);

  server.reset();  // the log is complete
  const std::string log = testing::slurp(dir_ + "/log.log");
  EXPECT_NE(log.find("/v1/subscribe"), std::string::npos) << "no access log";
  EXPECT_EQ(log.find(planner_), std::string::npos) << "a token in the log";
  EXPECT_EQ(log.find(planner_.substr(4, 16)), std::string::npos);
}

// Row 15: past 200 idle connections from one address, /healthz from that
// address got 503 like everything else. It is now answered (other requests
// still get 503 past the cap).
TEST_F(HostileRoundTwo, HealthzIsAnsweredPastTheAddressCap) {
  constexpr int kCap = 16;
  auto server =
      serve("cap", {"--max-connections-per-address", std::to_string(kCap)});
  const std::uint16_t port = testing::port_of(server->url());
  std::vector<int> idle;
  for (int i = 0; i < kCap + 8; ++i)
    idle.push_back(testing::connect_local(port));
  std::this_thread::sleep_for(300ms);
  const std::string health = testing::raw_exchange(
      port, "GET /healthz HTTP/1.1\r\nHost: a\r\nConnection: close\r\n\r\n");
  EXPECT_EQ(status_of(health), 200) << health;
  const std::string other = testing::raw_exchange(
      port, "GET /v1/sites HTTP/1.1\r\nHost: a\r\nConnection: close\r\n\r\n");
  EXPECT_EQ(status_of(other), 503) << other;
  EXPECT_NE(other.find("too many connections"), std::string::npos);
  for (int fd : idle) close(fd);
}

int attacks_each() {
  const char* env = std::getenv("ARSCOUT_ATTACKS");
  return env ? std::max(1, std::atoi(env)) : 4;
}

// Which rows attack (ARSCOUT_ATTACK_ROWS, e.g. "4,5": to find which one a
// slow /healthz comes from); all five by default.
bool attacks_row(int row) {
  const char* env = std::getenv("ARSCOUT_ATTACK_ROWS");
  if (!env) return true;
  const std::string rows = std::string(",") + env + ",";
  return rows.find("," + std::to_string(row) + ",") != std::string::npos;
}

// The acceptance of round two: rows 1, 2, 4, 5 and 6 at once, N clients
// each (ARSCOUT_ATTACKS; 32 for the figures in docs/RELIABILITY.md): the
// server answers /healthz within 100 ms throughout and its peak resident
// memory grows by under 300 MB.
TEST_F(HostileRoundTwo, TheServerStaysUpUnderEveryAttackAtOnce) {
  const int n = attacks_each();
  std::string blob(50 << 20, '\0');
  for (std::size_t i = 0; i < blob.size(); ++i)
    blob[i] = static_cast<char>((i * 2246822519u) >> 11);
  const std::string hash = store_->put_blob(blob);
  blob.clear();
  blob.shrink_to_fit();
  street_cloud::write_street_site(*store_, "street",
                                  street_cloud::synthetic_street(400000));
  auto server = serve("all", {"--max-streams-per-token", "1000"});
  const std::uint16_t port = testing::port_of(server->url());
  const std::string image = testing::noise_jpeg(2, 64, 48);
  const std::int64_t before_kib = server->rss_kib();
  std::atomic<int> exports_ok{0}, metadata_refused{0};
  // 413 for the part, or 429 past the token's 2 bodies at once.
  const auto refused = [](int status) {
    return status == 413 || status == 429;
  };
  // Made before the attack: the clients only send.
  const std::string many_objects =
      multipart_upload(scout_, empty_objects(300 << 10), image);
  const std::string many_zeros =
      multipart_upload(scout_, zeros(60 << 20), image);
  const auto t0 = Clock::now();
  std::vector<std::thread> clients;
  // The attackers share this machine's 2 cores with the server; at nice 10
  // (ARSCOUT_ATTACK_NICE, 0 to keep them at the server's priority) their
  // own sending (32 x 60 MB copied into loopback sockets at once) does not
  // count as the server's latency, as it would not from other machines.
  const char* nice_env = std::getenv("ARSCOUT_ATTACK_NICE");
  const int nice = nice_env ? std::atoi(nice_env) : 10;
  const auto attacker = [nice](auto work) {
    return [nice, work] {
      util::set_thread_nice(nice);
      work();
    };
  };
  for (int i = 0; i < n; ++i) {
    if (attacks_row(1))
      clients.emplace_back(attacker([&] {
        metadata_refused +=
            refused(status_of(testing::raw_exchange(port, many_objects)));
      }));
    if (attacks_row(2))
      clients.emplace_back(attacker([&] {
        metadata_refused +=
            refused(status_of(testing::raw_exchange(port, many_zeros)));
      }));
    if (attacks_row(4))
      clients.emplace_back(
          attacker([&] { never_read(port, planner_, hash, 10s); }));
    if (attacks_row(5))
      clients.emplace_back(attacker([&] {
        http::Client c({"http://127.0.0.1:" + std::to_string(port), planner_,
                        std::chrono::seconds(300)});
        const auto r = c.get("/v1/sites/street/export?format=las");
        exports_ok += r.status == 200 && r.body.size() > 1000000;
      }));
    if (attacks_row(6))
      clients.emplace_back(attacker([&] { huge_frame(port, planner_); }));
  }
  // Watched from once every client is started (this process starting 160
  // threads is not the server's latency) until every attack has ended.
  HealthWatch health(port);
  for (std::thread& t : clients) t.join();
  health.stop();
  const double seconds =
      std::chrono::duration<double>(Clock::now() - t0).count();
  const double grown_mb = (server->peak_rss_kib() - before_kib) / 1024.0;
  std::cout << n
            << " clients each of rows 1, 2, 4, 5 and 6 at once: " << seconds
            << " s; /healthz " << health.summary() << " (" << health.samples()
            << " samples, " << health.failures() << " failed); peak RSS +"
            << grown_mb << " MB; " << exports_ok << " LAS exports" << std::endl;
  EXPECT_EQ(metadata_refused, (attacks_row(1) + attacks_row(2)) * n);
  EXPECT_EQ(exports_ok, attacks_row(5) ? n : 0);
  EXPECT_EQ(health.failures(), 0);
  EXPECT_LT(grown_mb, kSanitized ? 900 : 300);
  // The acceptance's 100 ms is asserted in the long run only (ctest -L
  // long, alone on the machine): beside the suite's other tests, a time
  // says more about them than about this server.
  if (std::getenv("ARSCOUT_ATTACKS") && !kSanitized) {
    EXPECT_LT(health.slowest_ms(), 100);
  }
}

}  // namespace
}  // namespace arscout
