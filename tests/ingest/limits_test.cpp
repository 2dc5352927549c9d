// Hostile clients, round two (docs/RELIABILITY.md): the parts that are rules
// rather than sockets, checked through their own classes and Api directly.
// Each case failed before its fix; the ones that need a server process and
// its memory are in tests/reliability/hostile_round_two_test.cpp.
#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "api.h"
#include "api_handlers.h"
#include "arscout/db/store.h"
#include "arscout/http/byte_budget.h"
#include "arscout/http/keyed_rate.h"
#include "arscout/ingest/auth.h"
#include "client_limits.h"
#include "test_stores.h"

namespace arscout::ingest {

using http::ByteBudget;
using http::KeyedRate;
using http::parse_json_body;
using http::serve_static;
using http::StaticMount;
namespace {

using Clock = std::chrono::steady_clock;

std::string array_of_empty_objects(std::size_t n) {
  std::string text = "{\"a\":[";
  for (std::size_t i = 0; i < n; ++i) text += i ? ",{}" : "{}";
  return text + "]}";
}

double seconds_to_parse(const std::string& text) {
  double best = 1e9;
  for (int round = 0; round < 3; ++round) {
    const auto t0 = Clock::now();
    std::string error;
    EXPECT_TRUE(parse_json_body(text, &error)) << error;
    best = std::min(best,
                    std::chrono::duration<double>(Clock::now() - t0).count());
  }
  return best;
}

// Row 1: the depth-limited parser looked through the parent container at
// every closing bracket, so 80,000 empty objects took 2.1 s and 80,000
// keys 43 s. Four times the siblings now take about four times as long
// (a quadratic parse takes sixteen).
TEST(JsonBody, ParsingGrowsLinearlyWithTheNumberOfSiblings) {
  const double small = seconds_to_parse(array_of_empty_objects(20000));
  const double large = seconds_to_parse(array_of_empty_objects(80000));
  std::string keys = "{";
  for (int i = 0; i < 80000; ++i)
    keys += (i ? ",\"k" : "\"k") + std::to_string(i) + "\":{}";
  keys += "}";
  const double many_keys = seconds_to_parse(keys);
  std::cout << "20k empty objects " << small * 1000 << " ms, 80k "
            << large * 1000 << " ms, 80k keys " << many_keys * 1000 << " ms"
            << std::endl;
  EXPECT_LT(large / std::max(small, 1e-4), 8.0);
  EXPECT_LT(many_keys / std::max(large, 1e-4), 8.0);
}

// The builder gives what Json::parse gives, and refuses what it refused.
TEST(JsonBody, ValuesAndErrorsAreThoseOfTheLibraryParser) {
  for (const char* text :
       {R"({"a":1,"b":[true,false,null,"x",-2,3.5,18446744073709551615],)"
        R"("c":{"d":{"e":[]}},"a":2})",
        "[]", "\"just a string\"", "7", R"([{"u":"\u00e9\ud83d\ude00"}])"}) {
    std::string error;
    const auto ours = parse_json_body(text, &error);
    ASSERT_TRUE(ours) << text << ": " << error;
    EXPECT_EQ(*ours, Json::parse(text)) << text;
  }
  const auto refused = [](const std::string& text) {
    std::string error;
    EXPECT_FALSE(parse_json_body(text, &error)) << text;
    return error;
  };
  EXPECT_NE(refused("{\"a\":").find("malformed JSON at byte"),
            std::string::npos);
  EXPECT_NE(refused("[1] [2]").find("malformed JSON"), std::string::npos);
  EXPECT_NE(refused("[1e999]").find("unreadable JSON"), std::string::npos);
  EXPECT_NE(refused(std::string(600, '[') + std::string(600, ']'))
                .find("nested deeper than 512"),
            std::string::npos);
  std::string error;
  EXPECT_TRUE(
      parse_json_body(std::string(512, '[') + std::string(512, ']'), &error))
      << error;
}

TEST(KeyedRate, ABurstThenTheRateThenARefusalWithTheWait) {
  KeyedRate rate(3600, 3);  // one a second after three at once
  const auto t0 = Clock::now();
  for (int i = 0; i < 3; ++i) EXPECT_EQ(rate.take("a", t0), 0);
  EXPECT_EQ(rate.take("a", t0), 1);
  EXPECT_EQ(rate.wait("a", t0), 1);
  EXPECT_EQ(rate.take("b", t0), 0);  // keys are apart
  EXPECT_EQ(rate.take("a", t0 + std::chrono::milliseconds(1100)), 0);
  EXPECT_EQ(rate.take("a", t0 + std::chrono::milliseconds(1200)), 1);
  EXPECT_EQ(rate.wait("never seen", t0), 0);
  KeyedRate none(0, 1);
  for (int i = 0; i < 1000; ++i) EXPECT_EQ(none.take("a", t0), 0);
}

TEST(ByteBudget, PiecesWaitPastTheCapAndComeBackWhenReleased) {
  ByteBudget budget(1000);
  auto a = budget.take(600);
  ASSERT_TRUE(a);
  EXPECT_FALSE(budget.take(600));
  {
    auto b = budget.take(400);
    ASSERT_TRUE(b);
    EXPECT_EQ(budget.in_use(), 1000u);
  }
  EXPECT_EQ(budget.in_use(), 600u);
  a.reset();
  EXPECT_EQ(budget.in_use(), 0u);
  EXPECT_TRUE(budget.take(5000));  // alone, even a large piece goes
}

class ClientLimitsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    store_ = db::Store::open(testing::fresh_sqlite_url());
  }
  HttpRequest request(const std::string& method, const std::string& path,
                      const std::string& token,
                      const std::string& remote = "10.0.0.1") {
    HttpRequest r;
    r.method = method;
    r.target = r.path = path;
    r.remote = remote;
    if (!token.empty()) r.headers["authorization"] = "Bearer " + token;
    return r;
  }
  std::unique_ptr<db::Store> store_;
  Metrics metrics_;
};

// Row 13: 3,000 random tokens were all answered 401 at 3,461 a second.
// Past the address's failures every request from it is 429 with
// Retry-After, a valid token's too; other addresses are not affected.
TEST_F(ClientLimitsTest, FailedAuthenticationsAreThrottledPerAddress) {
  ServerOptions options;
  options.auth_failure_burst = 5;
  options.auth_failures_per_hour = 60;
  Api api(*store_, metrics_, options);
  const std::string planner = create_token(*store_, Role::kPlanner, "pat");
  int unauthorized = 0, throttled = 0;
  for (int i = 0; i < 50; ++i) {
    const HttpResponse r =
        api.handle(request("GET", "/v1/sites", "ars_" + std::to_string(i)));
    unauthorized += r.status == 401;
    throttled += r.status == 429;
  }
  EXPECT_EQ(unauthorized, 5);
  EXPECT_EQ(throttled, 45);
  const HttpResponse valid = api.handle(request("GET", "/v1/sites", planner));
  EXPECT_EQ(valid.status, 429);
  bool retry_after = false;
  for (const auto& [name, value] : valid.headers)
    retry_after |= name == "Retry-After" && std::stoi(value) >= 1;
  EXPECT_TRUE(retry_after);
  EXPECT_EQ(api.handle(request("GET", "/v1/sites", planner, "10.0.0.2")).status,
            200);
  // The refusal before a body says the same.
  const auto early =
      api.refuse_before_body(request("POST", "/v1/captures", "ars_x"));
  ASSERT_TRUE(early);
  EXPECT_EQ(early->status, 429);
}

std::string tiny_jpeg() {
  std::vector<uchar> bytes;
  cv::imencode(".jpg", cv::Mat(16, 16, CV_8UC3, cv::Scalar(90, 120, 150)),
               bytes);
  return std::string(bytes.begin(), bytes.end());
}

// Rows 8 and 9: one token sent 1,000 uploads at 308 a second, 100 of them
// 111 m apart founding 100 sites in 0.9 s, and 400 whose fixes stepped
// north dragged a site 8.7 km. Per token, uploads now have a rate and so
// do captures in new places; both answer 429 with Retry-After.
TEST_F(ClientLimitsTest, UploadsAndNewPlacesHaveARatePerToken) {
  ServerOptions options;
  options.upload_burst = 30;
  options.uploads_per_hour = 60;
  options.new_place_burst = 3;
  options.new_places_per_hour = 1;
  options.new_place_m = 500;
  Api api(*store_, metrics_, options);
  const std::string bob = create_token(*store_, Role::kScout, "bob");
  const std::string sam = create_token(*store_, Role::kScout, "sam");
  const auto upload = [&](const std::string& token, int i, double north_m) {
    HttpRequest r = request("POST", "/v1/captures", token);
    r.headers["content-type"] = "image/jpeg";
    r.headers["x-capture-metadata"] =
        Json{{"capture_id", "c" + std::to_string(i)},
             {"gps", {{"lat", 47.0 + north_m / 111195.0}, {"lon", 8.0}}}}
            .dump();
    r.body = tiny_jpeg();
    return api.handle(r);
  };
  // Fixes 111 m apart: a new place every fifth, three allowed at once.
  std::map<int, int> statuses;
  std::string last_kind;
  for (int i = 0; i < 25; ++i) {
    const HttpResponse r = upload(bob, i, 111.0 * i);
    ++statuses[r.status];
    if (r.status == 429) last_kind = Json::parse(r.body).value("error", "");
  }
  EXPECT_EQ(statuses[201], 15) << "places at 0, 555, 1110 m: 5 captures each";
  EXPECT_EQ(statuses[429], 10);
  EXPECT_EQ(last_kind, "too_many_new_places");
  // A stored site near the fix is no new place.
  store_->put("/sites/far", "site",
              Json{{"name", "far"},
                   {"gps", {{"lat", 47.0 + 5000 / 111195.0}, {"lon", 8.0}}}});
  EXPECT_EQ(upload(bob, 100, 5000).status, 201);
  // The upload rate: 30 at once, then 429 until the bucket refills.
  int stored = 0, refused = 0;
  for (int i = 0; i < 40; ++i) {
    const int status = upload(sam, i, 0).status;
    stored += status == 201;
    refused += status == 429;
  }
  EXPECT_EQ(stored, 30);
  EXPECT_EQ(refused, 10);
  const auto early =
      api.refuse_before_body(request("POST", "/v1/captures", sam));
  ASSERT_TRUE(early);
  EXPECT_EQ(early->status, 429);
}

// Row 10: "GET //" followed by the absolute folder of the web files was
// answered 301 to "//folder/" (a protocol-relative redirect naming a
// folder of the server). Row 12: no Content-Security-Policy,
// X-Frame-Options or Referrer-Policy on the pages.
TEST(StaticFiles, NoRedirectLeavesTheMountAndPagesCarryAPolicy) {
  namespace fs = std::filesystem;
  const std::string root = testing::make_temp_dir("static-mount");
  fs::create_directories(root + "/scout");
  std::ofstream(root + "/scout/index.html")
      << "<html><head><script type=\"importmap\">{\"imports\":{}}</script>"
         "<script type=\"module\" src=\"app.js\"></script></head></html>";
  std::ofstream(root + "/index.html") << "<html></html>";
  const std::vector<StaticMount> mounts = {{"/", root}};
  const auto get = [&](const std::string& path) {
    HttpRequest r;
    r.method = "GET";
    r.path = r.target = path;
    return *serve_static(mounts, r);
  };
  EXPECT_EQ(get("/scout").status, 301);
  for (const std::string& path : std::vector<std::string>{
           "/" + root + "/scout", "/" + root, "//etc", "/scout//index.html"}) {
    const HttpResponse r = get(path);
    EXPECT_EQ(r.status, 404) << path;
  }
  const HttpResponse page = get("/scout/");
  ASSERT_EQ(page.status, 200);
  std::map<std::string, std::string> headers(page.headers.begin(),
                                             page.headers.end());
  EXPECT_EQ(headers["X-Frame-Options"], "DENY");
  EXPECT_EQ(headers["Referrer-Policy"], "no-referrer");
  const std::string csp = headers["Content-Security-Policy"];
  EXPECT_NE(csp.find("default-src 'self'"), std::string::npos) << csp;
  EXPECT_NE(csp.find("frame-ancestors 'none'"), std::string::npos) << csp;
  // The import map runs by its hash, and nothing else inline does.
  EXPECT_NE(csp.find("'sha256-"), std::string::npos) << csp;
  EXPECT_EQ(csp.find("script-src 'self' 'unsafe"), std::string::npos) << csp;
}

}  // namespace
}  // namespace arscout::ingest
