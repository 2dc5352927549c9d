// What the API server offers other libraries: static files (the web
// viewer), routes added through ServerOptions::routes, and the
// ?access_token= a browser's WebSocket needs. Through the Api directly:
// these rules are about requests, not sockets.
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "api.h"
#include "arscout/db/store.h"
#include "arscout/ingest/auth.h"
#include "test_stores.h"

namespace arscout::ingest {

using http::StaticMount;
namespace {

namespace fs = std::filesystem;

void write_text(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path) << text;
}

HttpRequest get(const std::string& path, const std::string& token = "") {
  HttpRequest r;
  r.method = "GET";
  r.target = path;
  r.path = path;
  if (!token.empty()) r.headers["authorization"] = "Bearer " + token;
  return r;
}

class ExtensionsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    store_ = db::Store::open(testing::fresh_sqlite_url());
    token_ = create_token(*store_, Role::kPlanner, "pat");
    root_ = testing::make_temp_dir("web");
    write_text(root_ / "web/index.html", "<html>viewer</html>");
    write_text(root_ / "web/app.js", "export const x = 1;");
    write_text(root_ / "web/scout/index.html", "<html>scout</html>");
    write_text(root_ / "web/scout/manifest.webmanifest", "{}");
    write_text(root_ / "web/node_modules/three/build/three.module.js", "//3");
    write_text(root_ / "secret.txt", "not for the web");
    fs::create_symlink(root_ / "secret.txt", root_ / "web/leak.txt");
    ApiRoute echo;
    echo.name = "GET /v1/things/*/echo";
    echo.matches = [](const HttpRequest& r) {
      return r.path.rfind("/v1/things/", 0) == 0;
    };
    echo.handle = [](const HttpRequest& r, const Principal& who) {
      return HttpResponse::json(200, {{"path", r.path}, {"who", who.name}});
    };
    api_ = std::make_unique<Api>(
        *store_, metrics_, std::vector<ApiRoute>{echo},
        std::vector<StaticMount>{
            {"/", (root_ / "web").string()},
            {"/vendor/three/", (root_ / "web/node_modules/three").string()}});
  }

  std::unique_ptr<db::Store> store_;
  std::string token_;
  fs::path root_;
  Metrics metrics_;
  std::unique_ptr<Api> api_;
};

TEST_F(ExtensionsTest, StaticFilesNeedNoTokenAndStayInsideTheirFolder) {
  HttpResponse index = api_->handle(get("/"));
  EXPECT_EQ(index.status, 200);
  EXPECT_EQ(index.body, "<html>viewer</html>");
  EXPECT_EQ(index.content_type, "text/html; charset=utf-8");
  HttpResponse js = api_->handle(get("/app.js"));
  EXPECT_EQ(js.status, 200);
  EXPECT_EQ(js.content_type, "text/javascript; charset=utf-8");
  // The longest mount wins.
  EXPECT_EQ(api_->handle(get("/vendor/three/build/three.module.js")).body,
            "//3");
  for (const char* outside :
       {"/../secret.txt", "/vendor/three/../../../secret.txt", "/./app.js",
        "/leak.txt", "/missing.js", "/node_modules"})
    EXPECT_EQ(api_->handle(get(outside)).status, 404) << outside;
  // A folder with a page, named without its slash, sends the browser in.
  HttpResponse folder = api_->handle(get("/scout"));
  EXPECT_EQ(folder.status, 301);
  ASSERT_FALSE(folder.headers.empty());
  EXPECT_EQ(folder.headers[0].second, "/scout/");
  EXPECT_EQ(api_->handle(get("/scout/")).body, "<html>scout</html>");
  EXPECT_EQ(api_->handle(get("/scout/manifest.webmanifest")).content_type,
            "application/manifest+json");
  HttpRequest post = get("/app.js");
  post.method = "POST";
  EXPECT_EQ(api_->handle(post).status, 405);
  // The API is not shadowed by the "/" mount.
  EXPECT_EQ(api_->handle(get("/v1/sites")).status, 401);
  EXPECT_EQ(api_->handle(get("/healthz")).status, 200);
}

TEST_F(ExtensionsTest, AddedRoutesAnswerAfterAuthentication) {
  EXPECT_EQ(api_->handle(get("/v1/things/a/echo")).status, 401);
  HttpResponse r = api_->handle(get("/v1/things/a/echo", token_));
  ASSERT_EQ(r.status, 200);
  EXPECT_EQ(Json::parse(r.body)["who"], "pat");
  EXPECT_NE(metrics_.render().find("GET /v1/things/*/echo"), std::string::npos);
}

TEST_F(ExtensionsTest, WebSocketTakesTheTokenFromTheQuery) {
  HttpRequest r = get("/v1/subscribe");
  EXPECT_TRUE(std::holds_alternative<HttpResponse>(api_->check_subscribe(r)));
  r.query["access_token"] = "ars_wrong";
  EXPECT_TRUE(std::holds_alternative<HttpResponse>(api_->check_subscribe(r)));
  r.query["access_token"] = token_;
  EXPECT_TRUE(std::holds_alternative<Api::Subscribe>(api_->check_subscribe(r)));
  // Only the WebSocket takes it: elsewhere a URL token is not a login.
  HttpRequest sites = get("/v1/sites");
  sites.query["access_token"] = token_;
  EXPECT_EQ(api_->handle(sites).status, 401);
}

}  // namespace
}  // namespace arscout::ingest
