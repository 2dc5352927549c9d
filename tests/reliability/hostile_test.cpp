// Hostile clients (issue 19, docs/RELIABILITY.md "Hostile clients"): what a
// client may send that no well-behaved one does, against `arscout serve` in
// its own process so its memory can be measured. Each case failed before
// its fix.
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <iostream>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "arscout/db/store.h"
#include "arscout/http/change_stream.h"
#include "arscout/http/client.h"
#include "arscout/ingest/auth.h"
#include "arscout/ingest/image_budget.h"
#include "arscout/util/error.h"
#include "flaky_upload.h"
#include "png_bomb.h"
#include "raw_http.h"
#include "sanitized.h"
#include "serve_process.h"
#include "test_stores.h"

namespace arscout {
namespace {

using testing::kSanitized;

int count_of(const std::string& text, const std::string& what) {
  int n = 0;
  for (size_t at = text.find(what); at != std::string::npos;
       at = text.find(what, at + 1))
    ++n;
  return n;
}

class HostileClients : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing::make_temp_dir("hostile");
    url_ = testing::fresh_sqlite_url();
    auto store = db::Store::open(url_);
    planner_ = ingest::create_token(*store, ingest::Role::kPlanner, "pat");
    server_ = std::make_unique<testing::ServeProcess>(ARSCOUT_CLI, url_,
                                                      dir_ + "/serve.log");
    port_ = testing::port_of(server_->url());
  }

  std::string dir_, url_, planner_;
  std::unique_ptr<testing::ServeProcess> server_;
  std::uint16_t port_ = 0;
};

// Defect 10: "Transfer-Encoding: xchunked" framed the request as body-less,
// and its body ran as a second request (smuggling behind a proxy).
TEST_F(HostileClients, AnyTransferEncodingButChunkedIsRefusedAndClosed) {
  const std::string smuggled = "GET /healthz HTTP/1.1\r\nHost: a\r\n\r\n";
  for (const char* coding : {"xchunked", "gzip", "chunked, gzip", "identity"}) {
    const std::string reply = testing::raw_exchange(
        port_, std::string("POST /v1/captures HTTP/1.1\r\nHost: a\r\n") +
                   "Transfer-Encoding: " + coding + "\r\n\r\n" + smuggled);
    EXPECT_EQ(reply.rfind("HTTP/1.1 400", 0), 0u) << coding << ": " << reply;
    EXPECT_EQ(count_of(reply, "HTTP/1.1 "), 1) << coding << ": " << reply;
    EXPECT_EQ(reply.find("\"status\":\"ok\""), std::string::npos) << coding;
  }
  // Two Transfer-Encoding fields, even both chunked: refused (or, as Beast
  // does, dropped as a malformed header); never a second request.
  const std::string twice = testing::raw_exchange(
      port_,
      "POST /v1/captures HTTP/1.1\r\nHost: a\r\nTransfer-Encoding: chunked\r\n"
      "Transfer-Encoding: chunked\r\n\r\n0\r\n\r\n" +
          smuggled);
  EXPECT_TRUE(twice.empty() || twice.rfind("HTTP/1.1 400", 0) == 0) << twice;
  EXPECT_LE(count_of(twice, "HTTP/1.1 "), 1) << twice;
  // chunked itself still frames a body: without a token, the answer is 401.
  const std::string chunked = testing::raw_exchange(
      port_,
      "POST /v1/captures HTTP/1.1\r\nHost: a\r\nTransfer-Encoding: chunked\r\n"
      "\r\n5\r\nhello\r\n0\r\n\r\n");
  EXPECT_EQ(chunked.rfind("HTTP/1.1 401", 0), 0u) << chunked;
}

// Defect 3: without a token a client got "100 Continue" and could send up
// to 64 MiB per connection; 8 such uploads took the server from 370 to
// 862 MB. Now the header decides: 401 (or 403 for a role that may not make
// the request) before any body byte is read, then the connection closes.
TEST_F(HostileClients, BodiesWithoutATokenAreRefusedBeforeTheyAreRead) {
  constexpr std::uint64_t kBody = 60ull << 20;
  const std::int64_t before_kib = server_->rss_kib();
  const auto header = [&](const std::string& auth, bool expect) {
    return "POST /v1/captures HTTP/1.1\r\nHost: a\r\nContent-Type: "
           "image/jpeg\r\n"
           "Content-Length: " +
           std::to_string(kBody) + "\r\n" + auth +
           (expect ? "Expect: 100-continue\r\n" : "") + "\r\n";
  };
  const std::vector<std::string> auths = {
      "", "Authorization: Bearer ars_not_a_token\r\n",
      "Authorization: Bearer " + planner_ + "\r\n"};
  std::vector<testing::BodyAttempt> attempts(16);
  std::vector<std::thread> clients;
  for (size_t i = 0; i < attempts.size(); ++i) {
    clients.emplace_back([&, i] {
      attempts[i] = testing::send_large_body(
          port_, header(auths[i % auths.size()], i % 2 == 0), kBody);
    });
  }
  for (std::thread& t : clients) t.join();
  const std::int64_t peak_kib = server_->peak_rss_kib();
  for (size_t i = 0; i < attempts.size(); ++i) {
    const std::string& reply = attempts[i].reply;
    const bool planner = i % auths.size() == 2;
    EXPECT_EQ(reply.find("100 Continue"), std::string::npos) << i;
    EXPECT_LT(attempts[i].body_sent, kBody) << i << " sent the whole body";
    if (!reply.empty()) {  // a reset may come before the answer is read
      EXPECT_EQ(reply.rfind(planner ? "HTTP/1.1 403" : "HTTP/1.1 401", 0), 0u)
          << i << ": " << reply.substr(0, 200);
    }
  }
  const std::int64_t growth_mb = (peak_kib - before_kib) / 1024;
  std::cout << "16 refused 60 MiB bodies: server resident " << before_kib / 1024
            << " MB before, peak " << peak_kib / 1024 << " MB (+" << growth_mb
            << " MB)" << std::endl;
  EXPECT_LT(growth_mb, 50);
  // The answers came from the header: with Expect, no body byte was needed.
  int answered = 0;
  for (size_t i = 0; i < attempts.size(); i += 2)
    answered += !attempts[i].reply.empty();
  EXPECT_EQ(answered, 8);
}

// Defect 7: the request method became part of a metrics label: 50
// unauthenticated requests with long methods grew /metrics to 8.5 MB.
TEST_F(HostileClients, InventedMethodsDoNotGrowTheMetrics) {
  const auto metrics_size = [&] {
    const std::string reply =
        testing::raw_exchange(port_,
                              "GET /metrics HTTP/1.1\r\nHost: a\r\n"
                              "Connection: close\r\n\r\n");
    return reply.size();
  };
  for (int i = 0; i < 3; ++i)  // every route label a plain request makes
    testing::raw_exchange(port_,
                          "GET /v1/sites HTTP/1.1\r\nHost: a\r\n"
                          "Connection: close\r\n\r\n");
  const size_t before = metrics_size();
  for (int i = 0; i < 50; ++i) {
    const std::string method = std::string(4000, 'X') + std::to_string(i);
    for (const char* path : {"/v1/sites", "/v1/docs/a", "/index.html", "/x"})
      testing::raw_exchange(port_, method + " " + path +
                                       " HTTP/1.1\r\nHost: a\r\n"
                                       "Connection: close\r\n\r\n");
  }
  const size_t after = metrics_size();
  std::cout << "/metrics: " << before << " bytes before 200 requests with "
            << "invented methods, " << after << " after" << std::endl;
  EXPECT_LT(after, before + 8 * 1024);
}

// Defect 11: smaller ones. Satellites 2^32 + 1 were stored as 1; gps.time
// and taken were taken as any text; a second image part silently won; an
// id ".." in a viewer route answered 500.
TEST_F(HostileClients, MetadataIsCheckedBeforeItIsStored) {
  auto store = db::Store::open(url_);
  const std::string scout =
      ingest::create_token(*store, ingest::Role::kScout, "sam");
  http::Client client({server_->url(), scout});
  const std::string jpeg = testing::noise_jpeg(1, 64, 48);
  const auto upload = [&](const std::string& meta) {
    return client.request(
        "POST", "/v1/captures", jpeg,
        {{"Content-Type", "image/jpeg"}, {"X-Capture-Metadata", meta}});
  };
  for (const char* meta :
       {R"({"gps":{"lat":1,"lon":2,"satellites":4294967297}})",
        R"({"gps":{"lat":1,"lon":2,"satellites":-1}})",
        R"({"gps":{"lat":1,"lon":2,"time":"yesterday"}})",
        R"({"gps":{"lat":1,"lon":2,"time":"2026-13-40T99:00:00Z"}})",
        R"({"taken":"not a time"})"}) {
    const auto r = upload(meta);
    EXPECT_EQ(r.status, 422) << meta << ": " << r.body;
  }
  EXPECT_EQ(
      upload(
          R"({"gps":{"lat":1,"lon":2,"satellites":9,)"
          R"("time":"2026-11-21T13:05:00Z"},"taken":"2026-11-21T13:05:00Z"})")
          .status,
      201);
  // Two image parts: refused, not "the last wins".
  const std::string boundary = "XyZ";
  const auto part = [&](const std::string& name, const std::string& body) {
    return "--" + boundary + "\r\nContent-Disposition: form-data; name=\"" +
           name + "\"\r\n\r\n" + body + "\r\n";
  };
  const auto twice = client.request(
      "POST", "/v1/captures",
      part("image", jpeg) + part("image", testing::noise_jpeg(2, 64, 48)) +
          "--" + boundary + "--\r\n",
      {{"Content-Type", "multipart/form-data; boundary=" + boundary}});
  EXPECT_EQ(twice.status, 400) << twice.body;
  // A viewer route with the id ".." is a bad request, not a server error.
  for (const char* target :
       {"/v1/captures/%2E%2E/thumbnail.jpg", "/v1/captures/../overlay.jpg",
        "/v1/sites/%2E%2E/captures"}) {
    const auto r = client.get(target);
    EXPECT_TRUE(r.status == 400 || r.status == 404)
        << target << ": " << r.status << " " << r.body;
  }
  // Nothing of the refused ones was stored: one capture, the good one.
  const auto changes =
      client.get("/v1/changes?since=0&pattern=/captures/*").json();
  EXPECT_EQ(changes["changes"].size(), 1u) << changes.dump();
}

// A camera's id is its scout's own (round two, row 7): bob's PUT
// /v1/cameras/phone-a before alice's used to take the id, so alice's got 403
// and her captures were read with bob's intrinsics. Each scout's id now
// lives in its own space, as capture ids do; an admin's camera is the
// operators', which every scout may name; a camera stays capped in size.
TEST_F(HostileClients, CameraIdsBelongToTheScoutThatSendsThem) {
  auto store = db::Store::open(url_);
  const auto token = [&](ingest::Role role, const char* name) {
    return http::Client(
        {server_->url(), ingest::create_token(*store, role, name)});
  };
  http::Client alice = token(ingest::Role::kScout, "alice");
  http::Client bob = token(ingest::Role::kScout, "bob");
  http::Client root = token(ingest::Role::kAdmin, "root");
  const auto camera = [](double fx) {
    return nlohmann::json{
        {"fx", fx},     {"fy", fx},      {"cx", 319.5},          {"cy", 239.5},
        {"width", 640}, {"height", 480}, {"source", "estimated"}}
        .dump();
  };
  const auto put = [&](http::Client& who, const std::string& id,
                       const std::string& body) {
    return who.request("PUT", "/v1/cameras/" + id, body,
                       {{"Content-Type", "application/json"}});
  };
  const auto fx_of = [&](const std::string& path) {
    const auto doc = store->get(path);
    return doc ? doc->attrs.value("fx", 0.0) : -1.0;
  };
  // bob first, with wild intrinsics: alice is not refused.
  EXPECT_EQ(put(bob, "phone-a", camera(100)).status, 201);
  const auto mine = put(alice, "phone-a", camera(500));
  EXPECT_EQ(mine.status, 201) << mine.body;
  EXPECT_EQ(mine.json()["path"], "/cameras/alice.phone-a");
  EXPECT_EQ(put(alice, "phone-a", camera(510)).status, 200);
  EXPECT_EQ(fx_of("/cameras/alice.phone-a"), 510);
  EXPECT_EQ(fx_of("/cameras/bob.phone-a"), 100);
  // Neither may write the other's, even by its full id.
  EXPECT_EQ(put(bob, "alice.phone-a", camera(90)).status, 201);  // bob's own
  EXPECT_EQ(fx_of("/cameras/alice.phone-a"), 510);
  // alice's capture naming phone-a is read with her camera.
  const auto upload = alice.request(
      "POST", "/v1/captures", testing::noise_jpeg(7, 64, 48),
      {{"Content-Type", "image/jpeg"},
       {"X-Capture-Metadata",
        R"({"capture_id":"c1","camera":"phone-a","gps":{"lat":47.1,"lon":8.5}})"}});
  ASSERT_EQ(upload.status, 201) << upload.body;
  EXPECT_EQ(upload.json()["attrs"]["camera"], "alice.phone-a");
  // The operators' camera: written by an admin, named by any scout.
  EXPECT_EQ(put(root, "rig-1", camera(520)).status, 201);
  EXPECT_FALSE(store->get("/cameras/rig-1")->attrs.contains("owner"));
  const auto on_rig = bob.request(
      "POST", "/v1/captures", testing::noise_jpeg(8, 64, 48),
      {{"Content-Type", "image/jpeg"},
       {"X-Capture-Metadata",
        R"({"capture_id":"c2","camera":"rig-1","gps":{"lat":47.1,"lon":8.5}})"}});
  ASSERT_EQ(on_rig.status, 201) << on_rig.body;
  EXPECT_EQ(on_rig.json()["attrs"]["camera"], "rig-1");
  EXPECT_EQ(put(bob, "rig-1", camera(1)).status, 201);  // bob's own now
  EXPECT_EQ(fx_of("/cameras/rig-1"), 520);
  auto padded = nlohmann::json::parse(camera(530));
  padded["junk"] = std::string(1 << 20, 'j');
  EXPECT_EQ(put(alice, "phone-a", padded.dump()).status, 413);
}

// Defects 1 and 4: a PNG with one malformed zTXt chunk made the metadata
// read throw, the pixel check was skipped and OpenCV decoded it (a 420 KB
// 12000 x 12000 PNG cost +422 MB); a valid 16-bit RGBA PNG of 119.9 MP
// (910 KB) cost +912 MB; four thumbnails of a stored 144 MP PNG took the
// server to 1.98 GB. The budget is now read from the image's own header,
// in bytes, and every decode (uploads, thumbnails, overlays) goes through
// it and the one pool of decode slots.
TEST_F(HostileClients, DecodesStayWithinTheBudgetWhateverTheMetadataSays) {
  auto store = db::Store::open(url_);
  http::Client scout(
      {server_->url(),
       ingest::create_token(*store, ingest::Role::kScout, "sam")});
  const auto upload = [&](const std::string& png, const std::string& id) {
    return scout.request(
        "POST", "/v1/captures", png,
        {{"Content-Type", "image/png"},
         {"X-Capture-Metadata",
          R"({"capture_id":")" + id + R"(","gps":{"lat":47,"lon":15}})"}});
  };
  const std::int64_t before_kib = server_->rss_kib();
  const std::string bomb = testing::zero_png(12000, 12000, 2, 8, true);
  const auto bombed = upload(bomb, "bomb");
  EXPECT_EQ(bombed.status, 422) << bombed.body;
  const auto deep =
      upload(testing::png_header_only(10950, 10950, 6, 16), "deep");
  EXPECT_EQ(deep.status, 422) << deep.body;
  EXPECT_NE(deep.body.find("MiB decoded"), std::string::npos) << deep.body;
  const std::int64_t peak_kib = server_->peak_rss_kib();
  std::cout << "a " << bomb.size() / 1024
            << " KB 12000 x 12000 PNG with a bad zTXt and a 119.9 MP 16-bit "
               "RGBA header: refused, server peak +"
            << (peak_kib - before_kib) / 1024 << " MB" << std::endl;
  EXPECT_LT((peak_kib - before_kib) / 1024, 50);

  // The largest photo allowed (120 MP of 8-bit RGB, 360 MB decoded), and 16
  // thumbnails of it at once: no more decodes than slots run together.
  const std::string largest = testing::zero_png(10950, 10950, 2, 8, false);
  ASSERT_EQ(upload(largest, "largest").status, 201);
  const std::int64_t stored_kib = server_->rss_kib();
  std::vector<std::thread> viewers;
  std::vector<int> statuses(16);
  for (int i = 0; i < 16; ++i)
    viewers.emplace_back([&, i] {
      http::Client c({server_->url(), planner_, std::chrono::seconds(300)});
      statuses[i] = c.get("/v1/captures/sam.largest/thumbnail.jpg?size=" +
                          std::to_string(128 + i))
                        .status;
    });
  for (std::thread& t : viewers) t.join();
  for (int s : statuses) EXPECT_EQ(s, 200);
  const long slots = std::max(1u, std::thread::hardware_concurrency());
  // What ran before, each slot's decode, and room for the small things.
  const std::int64_t bound_mb =
      stored_kib / 1024 + slots * (ingest::kMaxDecodeBytes >> 20) + 150;
  const std::int64_t thumb_peak_mb = server_->peak_rss_kib() / 1024;
  std::cout << "16 thumbnails of a 120 MP PNG at once: server peak "
            << thumb_peak_mb << " MB (resident " << stored_kib / 1024
            << " MB before; bound: that + " << slots << " decode slots x "
            << (ingest::kMaxDecodeBytes >> 20) << " MiB + 150 MB = " << bound_mb
            << " MB)" << std::endl;
  // AddressSanitizer keeps freed memory in quarantine (256 MB) and adds
  // its shadow: there the figure is printed but not held to the bound.
  if (!kSanitized) {
    EXPECT_LT(thumb_peak_mb, bound_mb);
  }
}

// Defect 5: a scout or planner following the feed with pattern /auth/**
// (or the WebSocket) saw every token's SHA-256, name and revocation. The
// feed now carries only what the caller may read as a document.
TEST_F(HostileClients, TheFeedShowsNoTokensToScoutsOrPlanners) {
  auto store = db::Store::open(url_);
  const std::string admin =
      ingest::create_token(*store, ingest::Role::kAdmin, "root");
  const std::string scout =
      ingest::create_token(*store, ingest::Role::kScout, "sam");
  for (const std::string& token : {planner_, scout}) {
    http::Client client({server_->url(), token});
    for (const char* query :
         {"/v1/changes?since=0&pattern=/auth/**", "/v1/changes?since=0"}) {
      const auto answer = client.get(query).json();
      for (const auto& change : answer["changes"])
        EXPECT_NE(change["path"].get<std::string>().rfind("/auth", 0), 0u)
            << query << ": " << change.dump();
      EXPECT_GT(answer["last_seq"].get<std::int64_t>(), 0) << query;
    }
    // A long-poll on hidden changes only waits out its time, empty.
    const auto polled =
        client.get("/v1/changes?since=0&pattern=/auth/**&wait=1").json();
    EXPECT_TRUE(polled["changes"].empty()) << polled.dump();
    // The WebSocket: the scout's own /scouts/sam arrives, no token does.
    http::ChangeStream stream({server_->url(), token}, 0);
    int seen = 0;
    while (auto change = stream.next(std::chrono::milliseconds(1500))) {
      ++seen;
      EXPECT_NE((*change)["path"].get<std::string>().rfind("/auth", 0), 0u)
          << change->dump();
    }
    EXPECT_GE(seen, 1);
  }
  // An admin still sees the tokens.
  http::Client root({server_->url(), admin});
  const auto all = root.get("/v1/changes?since=0&pattern=/auth/**").json();
  EXPECT_EQ(all["changes"].size(), 3u) << all.dump();
}

// Defect 6: capture ids were global and predictable: bob uploading with
// capture_id "alice-0006.jpg" made alice's own upload of that photo fail
// with 409. Every id now lives in its scout's own space ("{name}.{id}"),
// and token names hold no '.', so two spaces never meet.
TEST_F(HostileClients, ScoutsCannotTakeEachOthersCaptureIds) {
  auto store = db::Store::open(url_);
  const std::string alice =
      ingest::create_token(*store, ingest::Role::kScout, "alice");
  const std::string bob =
      ingest::create_token(*store, ingest::Role::kScout, "bob");
  EXPECT_THROW(ingest::create_token(*store, ingest::Role::kScout, "al.ice"),
               util::Error);
  const auto upload = [&](const std::string& token, const std::string& id,
                          int image) {
    http::Client client({server_->url(), token});
    return client.request(
        "POST", "/v1/captures", testing::noise_jpeg(image, 64, 48),
        {{"Content-Type", "image/jpeg"},
         {"X-Capture-Metadata",
          R"({"capture_id":")" + id + R"(","gps":{"lat":47,"lon":15}})"}});
  };
  // Bob squats on every form of alice's next id first.
  for (const char* id : {"0006.jpg", "alice.0006.jpg", "alice-0006.jpg"}) {
    const auto squat = upload(bob, id, 1);
    ASSERT_EQ(squat.status, 201) << squat.body;
    EXPECT_EQ(squat.json()["path"], std::string("/captures/bob.") + id);
  }
  for (const char* id : {"0006.jpg", "alice.0006.jpg"}) {
    const auto mine = upload(alice, id, 2);
    EXPECT_TRUE(mine.status == 201) << id << ": " << mine.body;
    EXPECT_EQ(mine.json()["path"], "/captures/alice.0006.jpg") << id;
    EXPECT_EQ(mine.json()["attrs"]["scout"], "alice");
  }
  // Only bob's three and alice's one are stored.
  db::Query all;
  all.pattern = "/captures/*";
  EXPECT_EQ(store->query(all).size(), 4u);
}

// Defect 2: a long-poll held a worker thread for its whole wait: 32
// concurrent `GET /v1/changes?wait=20` blocked every other request,
// /healthz included, for 18 s. Long-polls and WebSocket streams now wait
// on one change watch, holding no thread; past a per-token cap they get
// 429.
TEST_F(HostileClients, LongPollsAndStreamsHoldNoWorkerThread) {
  constexpr int kPolls = 64, kStreams = 16;
  auto store = db::Store::open(url_);
  const std::string scout =
      ingest::create_token(*store, ingest::Role::kScout, "sam");
  testing::ServeProcess server(ARSCOUT_CLI, url_, dir_ + "/serve-streams.log",
                               {"--workers", "4", "--max-streams-per-token",
                                std::to_string(kPolls + kStreams)});
  const std::int64_t head = store->last_seq();
  const std::string poll =
      "/v1/changes?since=" + std::to_string(head) + "&wait=20";
  std::vector<int> statuses(kPolls, 0);
  std::vector<int> delivered(kPolls, -1);
  std::vector<std::thread> polls;
  for (int i = 0; i < kPolls; ++i)
    polls.emplace_back([&, i] {
      http::Client c({server.url(), scout, std::chrono::seconds(40)});
      const auto r = c.get(poll);
      statuses[i] = r.status;
      if (r.status == 200)
        delivered[i] = static_cast<int>(r.json()["changes"].size());
    });
  std::vector<std::unique_ptr<http::ChangeStream>> streams;
  for (int i = 0; i < kStreams; ++i)
    streams.push_back(std::make_unique<http::ChangeStream>(
        http::ClientOptions{server.url(), scout}, head));
  std::this_thread::sleep_for(std::chrono::seconds(1));  // all are waiting

  // 4 workers, 64 waiting clients: /healthz answers at once.
  http::Client probe({server.url(), ""});
  double slowest = 0;
  for (int i = 0; i < 10; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    EXPECT_EQ(probe.get("/healthz").status, 200);
    slowest = std::max(slowest, std::chrono::duration<double>(
                                    std::chrono::steady_clock::now() - t0)
                                    .count());
  }
  // One more from the same token is past its cap; another token's is not.
  http::Client more({server.url(), scout});
  const auto refused = more.get(poll);
  EXPECT_EQ(refused.status, 429) << refused.body;
  http::Client other({server.url(), planner_});
  EXPECT_EQ(
      other.get("/v1/changes?since=" + std::to_string(head) + "&wait=1").status,
      200);

  // A write wakes them all, well before their 20 s.
  const auto written = std::chrono::steady_clock::now();
  store->put("/notes/wake", "note", db::Json{{"n", 1}});
  for (std::thread& t : polls) t.join();
  const double woke =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - written)
          .count();
  for (int i = 0; i < kPolls; ++i) {
    EXPECT_EQ(statuses[i], 200) << i;
    EXPECT_EQ(delivered[i], 1) << i;
  }
  int streamed = 0;
  for (auto& stream : streams)
    streamed += stream->next(std::chrono::seconds(5)).has_value();
  EXPECT_EQ(streamed, kStreams);
  std::cout << kPolls << " long-polls and " << kStreams
            << " WebSocket streams open on 4 workers: slowest /healthz "
            << slowest * 1000 << " ms; a write woke every long-poll within "
            << woke << " s" << std::endl;
  // A worker held by a poll would hold /healthz for the poll's 20 s wait.
  // The bound is a tenth of that wait, not a latency figure: under the
  // sanitizers with the suite in parallel one answer took 0.21 s (CI,
  // 2026-12-06), where 0.1 s failed a server that held no thread.
  EXPECT_LT(slowest, 2.0);
  EXPECT_LT(woke, 5.0);
}

// Defect 3, the rest: no cap on connections, and a body sent a byte at a
// time kept its connection. Past the per-address cap a connection gets 503
// and is closed at once; a body slower than the minimum rate gets 408.
TEST_F(HostileClients, ConnectionsAreCappedAndSlowBodiesCutOff) {
  constexpr int kCap = 16;
  testing::ServeProcess server(
      ARSCOUT_CLI, url_, dir_ + "/serve-caps.log",
      {"--max-connections-per-address", std::to_string(kCap)});
  const std::uint16_t port = testing::port_of(server.url());
  std::vector<int> idle;
  for (int i = 0; i < kCap; ++i) idle.push_back(testing::connect_local(port));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  // (/healthz is still answered past the cap: HostileRoundTwo.
  // HealthzIsAnsweredPastTheAddressCap.)
  const std::string over =
      testing::raw_exchange(port, "GET /v1/sites HTTP/1.1\r\nHost: a\r\n\r\n");
  EXPECT_EQ(over.rfind("HTTP/1.1 503", 0), 0u) << over;
  EXPECT_NE(over.find("too many connections"), std::string::npos) << over;
  for (int fd : idle) close(fd);
  std::string again;
  for (int i = 0; i < 50 && again.rfind("HTTP/1.1 401", 0) != 0; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    again = testing::raw_exchange(
        port, "GET /v1/sites HTTP/1.1\r\nHost: a\r\nConnection: close\r\n\r\n");
  }
  EXPECT_EQ(again.rfind("HTTP/1.1 401", 0), 0u) << again;

  // A scout's upload trickled at a byte every 2 s: cut off after the first
  // 10 s window, not left open for its 30 s + 16 s deadline.
  auto store = db::Store::open(url_);
  const std::string scout =
      ingest::create_token(*store, ingest::Role::kScout, "sam");
  const int fd = testing::connect_local(port);
  ASSERT_GE(fd, 0);
  const std::string header =
      "POST /v1/captures HTTP/1.1\r\nHost: a\r\nAuthorization: Bearer " +
      scout + "\r\nContent-Type: image/jpeg\r\nContent-Length: 1048576\r\n\r\n";
  send(fd, header.data(), header.size(), MSG_NOSIGNAL);
  const auto t0 = std::chrono::steady_clock::now();
  std::string reply;
  while (std::chrono::steady_clock::now() - t0 < std::chrono::seconds(40)) {
    char c = 'x', buf[4096];
    const ssize_t n = recv(fd, buf, sizeof buf, MSG_DONTWAIT);
    if (n > 0) reply.append(buf, static_cast<size_t>(n));
    if (n == 0 || send(fd, &c, 1, MSG_NOSIGNAL) != 1) break;
    std::this_thread::sleep_for(std::chrono::seconds(2));
  }
  close(fd);
  const double cut =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0)
          .count();
  std::cout << "a body at 0.5 bytes/s: cut off after " << cut << " s ("
            << (reply.empty() ? "closed" : reply.substr(0, 12)) << ")"
            << std::endl;
  EXPECT_LT(cut, 25.0);
  if (!reply.empty()) {
    EXPECT_EQ(reply.rfind("HTTP/1.1 408", 0), 0u) << reply;
  }
}

}  // namespace
}  // namespace arscout
