// Hostile clients (issue 19, docs/RELIABILITY.md "Hostile clients"): what a
// client may send that no well-behaved one does, against `arscout serve` in
// its own process so its memory can be measured. Each case failed before
// its fix.
#include <chrono>
#include <iostream>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "arscout/db/store.h"
#include "arscout/ingest/auth.h"
#include "flaky_upload.h"
#include "raw_http.h"
#include "serve_process.h"
#include "test_stores.h"

namespace arscout {
namespace {

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

}  // namespace
}  // namespace arscout
