// Token lifecycle across servers (issue 19): two `arscout serve` processes
// on one PostgreSQL database; a token revoked (or expired) through the
// store is refused by both within a second, and its open change streams
// are closed.
#include <chrono>
#include <thread>

#include <gtest/gtest.h>

#include "arscout/db/store.h"
#include "arscout/http/change_stream.h"
#include "arscout/http/client.h"
#include "arscout/ingest/auth.h"
#include "arscout/util/clock.h"
#include "arscout/util/error.h"
#include "serve_process.h"
#include "test_stores.h"

namespace arscout {
namespace {

using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;

using util::seconds_since;

// Seconds until `token` is answered 401 on /v1/sites by `server`.
double until_refused(const std::string& server, const std::string& token) {
  const auto start = Clock::now();
  http::Client client({server, token});
  while (client.get("/v1/sites").status != 401) {
    if (seconds_since(start) > 10) return 99;
    std::this_thread::sleep_for(20ms);
  }
  return seconds_since(start);
}

// Seconds until the stream ends (NetworkError from next()).
double until_closed(http::ChangeStream& stream) {
  const auto start = Clock::now();
  try {
    while (seconds_since(start) < 10) stream.next(100ms);
  } catch (const http::NetworkError&) {
    return seconds_since(start);
  }
  return 99;
}

TEST(TokenLifecycle, ARevokedTokenIsRefusedByEveryServerAndItsStreamsClose) {
  std::string url;
  ARSCOUT_FRESH_STORE_OR_SKIP(url, "postgresql");
  const std::string dir = testing::make_temp_dir("tokens");
  auto store = db::Store::open(url);
  const std::string token =
      ingest::create_token(*store, ingest::Role::kPlanner, "pat");
  const std::string other =
      ingest::create_token(*store, ingest::Role::kPlanner, "quinn");
  testing::ServeProcess a(ARSCOUT_CLI, url, dir + "/a.log");
  testing::ServeProcess b(ARSCOUT_CLI, url, dir + "/b.log");
  for (const auto* s : {&a, &b})
    ASSERT_EQ(http::Client({s->url(), token}).get("/v1/sites").status, 200);
  http::ChangeStream stream_a({a.url(), token}, 0);
  http::ChangeStream stream_b({b.url(), token}, 0);
  http::ChangeStream bystander({b.url(), other}, 0);

  const auto revoked = ingest::revoke_tokens(*store, "", "pat");
  ASSERT_EQ(revoked.size(), 1u);
  const double refused_a = until_refused(a.url(), token);
  const double refused_b = until_refused(b.url(), token);
  const double closed_a = until_closed(stream_a);
  const double closed_b = until_closed(stream_b);
  std::printf(
      "revoked: refused by A after %.2f s, by B after %.2f s; "
      "streams closed after %.2f s and %.2f s\n",
      refused_a, refused_b, closed_a, closed_b);
  EXPECT_LT(refused_a, 1.0);
  EXPECT_LT(refused_b, 1.0);
  // Each stream is checked every second: closed within about a second of
  // the revocation (the two waits run one after the other).
  EXPECT_LT(closed_a, 1.5);
  EXPECT_LT(closed_b, 1.5);
  // The other token's stream and requests go on.
  EXPECT_NO_THROW(bystander.next(1500ms));
  EXPECT_EQ(http::Client({a.url(), other}).get("/v1/sites").status, 200);
  // The revoked token's document stays, marked.
  const auto tokens = ingest::list_tokens(*store);
  ASSERT_EQ(tokens.size(), 2u);
  for (const auto& t : tokens)
    EXPECT_EQ(t.state(std::time(nullptr)),
              t.name == "pat" ? "revoked" : "active");
}

TEST(TokenLifecycle, AnExpiredTokenIsRefused) {
  const std::string url = testing::fresh_sqlite_url();
  const std::string dir = testing::make_temp_dir("tokens-expiry");
  auto store = db::Store::open(url);
  testing::ServeProcess server(ARSCOUT_CLI, url, dir + "/serve.log");
  // Expiries are whole seconds: 3 s from now is 2-3 s of validity, ample
  // for the two requests even on a loaded machine.
  const std::string token = ingest::create_token(*store, ingest::Role::kScout,
                                                 "sam", std::time(nullptr) + 3);
  http::Client client({server.url(), token});
  EXPECT_EQ(client.get("/v1/sites").status, 200);
  http::ChangeStream stream({server.url(), token}, 0);
  std::this_thread::sleep_for(4s);
  EXPECT_EQ(client.get("/v1/sites").status, 401);
  EXPECT_LT(until_closed(stream), 1.5);
  EXPECT_THROW(ingest::create_token(*store, ingest::Role::kScout, "late",
                                    std::time(nullptr) - 1),
               util::Error);
}

}  // namespace
}  // namespace arscout
