// The API's route table (api.cpp, route_table.h): which route a request
// is, 404 against 405 with Allow, 401 and 403 by role, the metrics labels,
// the refusal before a body agreeing with the full answer, and the one
// mapping of store errors to statuses (http_types.h). Through Api directly:
// these are rules about requests, not sockets.
#include <gtest/gtest.h>

#include <chrono>

#include "api.h"
#include "arscout/db/errors.h"
#include "arscout/db/store.h"
#include "arscout/ingest/auth.h"
#include "arscout/util/error.h"
#include "route_table.h"
#include "test_stores.h"

namespace arscout::ingest {
namespace {

HttpRequest request(const std::string& method, const std::string& path,
                    const std::string& token) {
  HttpRequest r;
  r.method = method;
  r.target = path;
  r.path = path;
  if (!token.empty()) r.headers["authorization"] = "Bearer " + token;
  return r;
}

std::string allow_of(const HttpResponse& r) {
  for (const auto& [name, value] : r.headers)
    if (name == "Allow") return value;
  return "";
}

TEST(RoutePatterns, StarsMatchOneSegmentOrTheRest) {
  std::string rest = "unset";
  EXPECT_TRUE(pattern_matches("/v1/sites", "/v1/sites"));
  EXPECT_FALSE(pattern_matches("/v1/sites", "/v1/sites/"));
  EXPECT_FALSE(pattern_matches("/v1/sites", "/v1/sitesx"));
  EXPECT_FALSE(pattern_matches("/v1/blobs/*", "/v1/blobs"));
  EXPECT_TRUE(pattern_matches("/v1/blobs/*", "/v1/blobs/", &rest));
  EXPECT_EQ(rest, "");
  EXPECT_TRUE(pattern_matches("/v1/docs/*", "/v1/docs/a/b/", &rest));
  EXPECT_EQ(rest, "a/b/");
  EXPECT_TRUE(pattern_matches("/v1/captures/*/thumb", "/v1/captures/c/thumb"));
  EXPECT_FALSE(pattern_matches("/v1/captures/*/thumb", "/v1/captures//thumb"));
  EXPECT_FALSE(
      pattern_matches("/v1/captures/*/thumb", "/v1/captures/a/b/thumb"));
  EXPECT_FALSE(
      pattern_matches("/v1/captures/*/thumb", "/v1/captures/c/thumb/"));
  EXPECT_FALSE(pattern_matches("/healthz", ""));
  EXPECT_FALSE(pattern_matches("/healthz", "healthz"));
}

TEST(RoutePatterns, RolesAreOrderedPlannerScoutAdmin) {
  EXPECT_TRUE(role_at_least(Role::kScout, Role::kPlanner));
  EXPECT_FALSE(role_at_least(Role::kPlanner, Role::kScout));
  EXPECT_TRUE(role_at_least(Role::kAdmin, Role::kScout));
  EXPECT_FALSE(role_at_least(Role::kScout, Role::kAdmin));
}

TEST(StoreErrors, OneStatusPerCode) {
  using db::ErrorCode;
  const std::pair<ErrorCode, int> expected[] = {
      {ErrorCode::kInvalidPath, 400},     {ErrorCode::kInvalidJson, 400},
      {ErrorCode::kNotFound, 404},        {ErrorCode::kUnknownBlob, 404},
      {ErrorCode::kConflict, 409},        {ErrorCode::kTooLarge, 413},
      {ErrorCode::kInvalidDocument, 422}, {ErrorCode::kInvalidArgument, 422},
      {ErrorCode::kUnavailable, 503},     {ErrorCode::kInternal, 500}};
  for (const auto& [code, status] : expected) {
    EXPECT_EQ(http_status(code), status) << db::to_string(code);
    const HttpResponse r = error_response(db::StoreError(code, "why"));
    EXPECT_EQ(r.status, status);
    EXPECT_EQ(Json::parse(r.body)["error"], db::to_string(code));
  }
  const HttpResponse conflict = error_response(db::ConflictError("/a", 1, 2));
  EXPECT_EQ(Json::parse(conflict.body)["current_version"], 2);
  EXPECT_EQ(allow_of(error_response(
                db::StoreError(db::ErrorCode::kUnavailable, "down"))),
            "");
}

// An error that is not the store's answers as the store's code of its kind.
TEST(StoreErrors, AnErrorOfAnotherKindAnswersAsItsCode) {
  const std::pair<util::ErrorKind, int> expected[] = {
      {util::ErrorKind::kInvalidArgument, 422},
      {util::ErrorKind::kInvalidJson, 400},
      {util::ErrorKind::kNotFound, 404},
      {util::ErrorKind::kConflict, 409},
      {util::ErrorKind::kUnavailable, 503},
      {util::ErrorKind::kInternal, 500}};
  for (const auto& [kind, status] : expected) {
    const HttpResponse r = error_response(util::Error(kind, "why"));
    EXPECT_EQ(r.status, status);
    EXPECT_EQ(Json::parse(r.body)["error"], db::to_string(db::code_of(kind)));
    EXPECT_EQ(Json::parse(r.body)["message"], "why");
  }
}

class RoutesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    store_ = db::Store::open(testing::fresh_sqlite_url());
    tokens_["scout"] = create_token(*store_, Role::kScout, "sam");
    tokens_["planner"] = create_token(*store_, Role::kPlanner, "pat");
    tokens_["admin"] = create_token(*store_, Role::kAdmin, "root");
    tokens_["none"] = "";
    ApiRoute thumb;
    thumb.name = "GET /v1/captures/*/thumb";
    thumb.methods = {"GET"};
    thumb.pattern = "/v1/captures/*/thumb";
    thumb.handle = [](const HttpRequest&, const Principal&) {
      return HttpResponse::json(200, Json::object());
    };
    api_ = std::make_unique<Api>(*store_, metrics_, std::vector{thumb});
  }

  HttpResponse as(const std::string& who, const std::string& method,
                  const std::string& path) {
    return api_->handle(request(method, path, tokens_.at(who)));
  }

  std::unique_ptr<db::Store> store_;
  std::map<std::string, std::string> tokens_;
  Metrics metrics_;
  std::unique_ptr<Api> api_;
};

struct Case {
  std::string who, method, path;
  int status;
  std::string allow;  // the Allow header of a 405
};

TEST_F(RoutesTest, EveryRouteAnswersUnknownPathsMethodsAndRoles) {
  const Case cases[] = {
      {"none", "GET", "/healthz", 200, ""},
      {"none", "HEAD", "/healthz", 405, "GET"},
      {"none", "POST", "/metrics", 405, "GET"},
      {"none", "GET", "/v1/nowhere", 404, ""},
      {"scout", "GET", "/v1/docs", 404, ""},
      {"scout", "GET", "/v1/capturesx", 404, ""},
      {"none", "GET", "/v1/sites", 401, ""},
      {"planner", "POST", "/v1/sites", 405, "GET"},
      {"planner", "GET", "/v1/captures", 405, "POST"},
      {"planner", "POST", "/v1/captures", 403, ""},
      {"planner", "GET", "/v1/cameras/c1", 405, "PUT"},
      {"planner", "PUT", "/v1/cameras/c1", 403, ""},
      {"scout", "GET", "/v1/captures/c1", 405, "DELETE"},
      {"scout", "DELETE", "/v1/captures/c1", 404, ""},
      {"scout", "POST", "/v1/blobs/x", 405, "GET"},
      {"scout", "GET", "/v1/docs/sites/none", 404, ""},
      {"scout", "PUT", "/v1/docs/a", 403, ""},
      {"scout", "POST", "/v1/docs/a", 403, ""},
      {"admin", "POST", "/v1/docs/a", 405, "GET, HEAD, PUT, PATCH, DELETE"},
      {"planner", "HEAD", "/v1/docs/a", 404, ""},  // GET's answer
      {"planner", "GET", "/v1/docs/auth/tokens", 403, ""},
      {"planner", "PUT", "/v1/subscribe", 400, ""},
      // An added route wins over DELETE /v1/captures/{id}.
      {"planner", "GET", "/v1/captures/c1/thumb", 200, ""},
      {"admin", "DELETE", "/v1/captures/c1/thumb", 405, "GET"},
      {"none", "GET", "/v1/captures/c1/thumb", 401, ""},
  };
  for (const Case& c : cases) {
    const std::string what = c.who + " " + c.method + " " + c.path;
    const HttpResponse r = as(c.who, c.method, c.path);
    EXPECT_EQ(r.status, c.status) << what << ": " << r.body;
    EXPECT_EQ(allow_of(r), c.allow) << what;
  }
}

TEST_F(RoutesTest, TheCheckBeforeTheBodyAgreesWithTheAnswer) {
  const Case cases[] = {
      {"none", "POST", "/v1/captures", 401, ""},
      {"none", "PUT", "/v1/nowhere", 401, ""},  // no body without a token
      {"planner", "POST", "/v1/captures", 403, ""},
      {"planner", "PUT", "/v1/cameras/c1", 403, ""},
      {"scout", "PUT", "/v1/docs/sites/s1", 403, ""},
      {"scout", "PATCH", "/v1/docs/sites/s1", 403, ""},
      {"scout", "POST", "/v1/captures", 0, ""},
      {"admin", "PUT", "/v1/docs/sites/s1", 0, ""},
      {"none", "POST", "/healthz", 0, ""},
  };
  for (const Case& c : cases) {
    const std::string what = c.who + " " + c.method + " " + c.path;
    const HttpRequest head = request(c.method, c.path, tokens_.at(c.who));
    const auto refusal = api_->refuse_before_body(head);
    ASSERT_EQ(refusal.has_value(), c.status != 0) << what;
    if (!refusal) continue;
    EXPECT_EQ(refusal->status, c.status) << what;
    if (c.path == "/v1/nowhere") continue;
    const HttpResponse full = api_->handle(head);
    EXPECT_EQ(full.status, refusal->status) << what;
    EXPECT_EQ(full.body, refusal->body) << what;
  }
}

TEST_F(RoutesTest, MetricsLabelsComeFromTheTable) {
  EXPECT_EQ(api_->route_template("GET", "/v1/docs/a/b"), "GET /v1/docs/*");
  EXPECT_EQ(api_->route_template("PUT", "/v1/docs/a"), "PUT /v1/docs/*");
  EXPECT_EQ(api_->route_template("POST", "/v1/captures"), "POST /v1/captures");
  EXPECT_EQ(api_->route_template("BREW", "/v1/captures/x"),
            "OTHER /v1/captures/*");
  EXPECT_EQ(api_->route_template("DELETE", "/v1/captures/x/thumb"),
            "GET /v1/captures/*/thumb");
  EXPECT_EQ(api_->route_template("GET", "/healthz"), "GET /healthz");
  EXPECT_EQ(api_->route_template("GET", "/v1/nowhere"), "other");
  as("scout", "GET", "/v1/nowhere");
  as("planner", "PATCH", "/v1/changes");
  const std::string text = metrics_.render();
  EXPECT_NE(text.find("route=\"other\""), std::string::npos) << text;
  EXPECT_NE(text.find("route=\"PATCH /v1/changes\""), std::string::npos)
      << text;
}

TEST(RoutesOperationsOnly, OnlyHealthAndMetricsWithoutTheApi) {
  auto store = db::Store::open(testing::fresh_sqlite_url());
  Metrics metrics;
  ServerOptions options;
  options.serve_api = false;
  Api api(*store, metrics, options);
  EXPECT_EQ(api.handle(request("GET", "/healthz", "")).status, 200);
  EXPECT_EQ(api.handle(request("GET", "/metrics", "")).status, 200);
  const HttpResponse sites = api.handle(request("GET", "/v1/sites", ""));
  EXPECT_EQ(sites.status, 404);
  EXPECT_NE(sites.body.find("only /healthz"), std::string::npos);
  const auto early = api.refuse_before_body(request("POST", "/v1/sites", ""));
  ASSERT_TRUE(early.has_value());
  EXPECT_EQ(early->status, 404);
}

}  // namespace
}  // namespace arscout::ingest

namespace arscout::ingest {
namespace {

std::string header_of(const HttpResponse& r, const std::string& name) {
  for (const auto& [n, value] : r.headers)
    if (n == name) return value;
  return "";
}

// GET /v1/me says who a token is; every 401 says why there is no one, by a
// reason a client can act on (issue 38: the scout app's sign-in).
TEST_F(RoutesTest, MeNamesTheTokenAndEvery401SaysWhy) {
  const HttpResponse sam = as("scout", "GET", "/v1/me");
  ASSERT_EQ(sam.status, 200) << sam.body;
  EXPECT_EQ(Json::parse(sam.body),
            (Json{{"name", "sam"}, {"role", "scout"}, {"expires", nullptr}}));
  EXPECT_EQ(Json::parse(as("planner", "GET", "/v1/me").body)["role"],
            "planner");
  const std::int64_t now_s =
      std::chrono::duration_cast<std::chrono::seconds>(
          std::chrono::system_clock::now().time_since_epoch())
          .count();
  const std::string soon =
      create_token(*store_, Role::kScout, "kim", now_s + 3600);
  tokens_["kim"] = soon;
  const Json kim = Json::parse(as("kim", "GET", "/v1/me").body);
  EXPECT_EQ(kim["name"], "kim");
  EXPECT_TRUE(kim["expires"].is_string());
  EXPECT_EQ(as("scout", "POST", "/v1/me").status, 405);

  const auto reason = [&](const HttpRequest& r) {
    const HttpResponse answer = api_->handle(r);
    EXPECT_EQ(answer.status, 401) << answer.body;
    EXPECT_NE(header_of(answer, "WWW-Authenticate").find("Bearer"),
              std::string::npos);
    return Json::parse(answer.body).value("reason", "");
  };
  EXPECT_EQ(reason(request("GET", "/v1/me", "")), "missing");
  HttpRequest basic = request("GET", "/v1/me", "");
  basic.headers["authorization"] = "Basic YTpi";
  EXPECT_EQ(reason(basic), "malformed");
  EXPECT_EQ(reason(request("GET", "/v1/me", std::string(201, 'x'))),
            "malformed");
  EXPECT_EQ(reason(request("GET", "/v1/me", "ars_nosuchtoken")), "unknown");
  revoke_tokens(*store_, "", "sam");
  EXPECT_EQ(reason(request("GET", "/v1/me", tokens_.at("scout"))), "revoked");
  EXPECT_EQ(reason(request("GET", "/v1/sites", tokens_.at("scout"))),
            "revoked");  // every route, not only /v1/me
  // An expired token: its stored expiry moved into the past.
  for (const TokenInfo& t : list_tokens(*store_))
    if (t.name == "kim")
      store_->patch("/auth/tokens/" + t.id,
                    Json{{"expires", "2020-01-01T00:00:00Z"}});
  EXPECT_EQ(reason(request("GET", "/v1/me", soon)), "expired");
}

// PATCH /v1/sites/{id}: planners and admins rename a site; scouts may not;
// the body is one name; a site that grew into another says which.
TEST_F(RoutesTest, SitesAreRenamedByPlannersAndAdmins) {
  store_->put("/sites/s-1", "site",
              Json{{"name", "s-1"}, {"captures", Json::array()}});
  store_->put(
      "/sites/s-0", "site",
      Json{{"name", "s-0"}, {"merged_into", "s-1"}, {"state", "merged"}});
  const auto rename = [&](const std::string& who, const std::string& path,
                          const std::string& body) {
    HttpRequest r = request("PATCH", path, tokens_.at(who));
    r.body = body;
    return api_->handle(r);
  };
  const HttpResponse ok =
      rename("planner", "/v1/sites/s-1", R"({"name": "  North block  "})");
  ASSERT_EQ(ok.status, 200) << ok.body;
  EXPECT_EQ(Json::parse(ok.body)["attrs"]["name"], "North block");
  EXPECT_EQ(store_->get("/sites/s-1")->attrs["name"], "North block");
  EXPECT_EQ(store_->get("/sites/s-1")->author, "pat");
  EXPECT_EQ(rename("admin", "/v1/sites/s-1", R"({"name": "Block 7"})").status,
            200);
  EXPECT_EQ(store_->get("/sites/s-1")->attrs["captures"], Json::array());
  const struct {
    std::string who, path, body;
    int status;
  } refused[] = {
      {"scout", "/v1/sites/s-1", R"({"name": "mine"})", 403},
      {"none", "/v1/sites/s-1", R"({"name": "x"})", 401},
      {"planner", "/v1/sites/nowhere", R"({"name": "x"})", 404},
      {"planner", "/v1/sites/s-1/model", R"({"name": "x"})", 404},
      {"planner", "/v1/sites/s-0", R"({"name": "x"})", 409},
      {"planner", "/v1/sites/s-1", "not json", 400},
      {"planner", "/v1/sites/s-1", R"({"name": ""})", 422},
      {"planner", "/v1/sites/s-1", R"({"name": "   "})", 422},
      {"planner", "/v1/sites/s-1", R"({"name": 7})", 422},
      {"planner", "/v1/sites/s-1", R"({"name": "a", "state": "x"})", 422},
      {"planner", "/v1/sites/s-1", R"({"name": "tab\there"})", 422},
      {"planner", "/v1/sites/s-1",
       "{\"name\": \"" + std::string(121, 'a') + "\"}", 422},
  };
  for (const auto& c : refused) {
    const HttpResponse r = rename(c.who, c.path, c.body);
    EXPECT_EQ(r.status, c.status)
        << c.who << " " << c.path << " " << c.body << ": " << r.body;
  }
  EXPECT_EQ(store_->get("/sites/s-1")->attrs["name"], "Block 7");
  EXPECT_EQ(as("planner", "GET", "/v1/sites/s-1").status, 405);
}

}  // namespace
}  // namespace arscout::ingest
