// The mesh endpoints the web viewer streams from (mesh_routes.h,
// docs/api.md), through the API server, on the synthetic mesh site
// (synthetic_mesh_site.h): the listing against the stored levels and their
// meshes' boxes, the levels' bytes against the stored GLBs, the caching
// headers, and every error.
#include <memory>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "arscout/db/store.h"
#include "arscout/http/client.h"
#include "arscout/ingest/auth.h"
#include "arscout/ingest/server.h"
#include "arscout/util/sha256.h"
#include "arscout/viewer/routes.h"
#include "mesh_routes.h"
#include "synthetic_mesh_site.h"
#include "test_stores.h"

namespace arscout::viewer {
namespace {

using Json = nlohmann::json;

class MeshRoutes : public ::testing::Test {
 protected:
  void SetUp() override {
    store_ = db::Store::open(testing::fresh_sqlite_url());
    tiles_ = mesh_site::write_mesh_site(*store_, "m1");
    mesh_site::write_mesh_site(*store_, "bare", true, false);
    ingest::ServerOptions options;
    options.port = 0;
    options.routes = viewer_routes(*store_);
    server_ = std::make_unique<ingest::Server>(*store_, options);
    server_->start();
    client_options_.server =
        "http://127.0.0.1:" + std::to_string(server_->port());
    client_options_.token =
        ingest::create_token(*store_, ingest::Role::kPlanner, "pat");
    client_ = std::make_unique<http::Client>(client_options_);
  }
  void TearDown() override {
    client_.reset();
    if (server_) server_->stop();
  }

  http::HttpResult get(const std::string& target,
                       const std::string& if_none_match = "") {
    if (if_none_match.empty()) return client_->get(target);
    return client_->request("GET", target, "",
                            {{"If-None-Match", if_none_match}});
  }

  std::unique_ptr<db::Store> store_;
  std::vector<mesh_site::MeshTile> tiles_;
  std::unique_ptr<ingest::Server> server_;
  http::ClientOptions client_options_;
  std::unique_ptr<http::Client> client_;
};

TEST_F(MeshRoutes, ListingNamesEveryLevelWithItsBoxAndTheVersion) {
  const auto got = get("/v1/sites/m1/mesh");
  ASSERT_EQ(got.status, 200) << got.body;
  EXPECT_EQ(got.headers.at("cache-control"), "no-cache");
  const Json listing = got.json();
  EXPECT_EQ(listing["site"], "m1");
  EXPECT_EQ(listing["version"], store_->get("/sites/m1/model")->version);
  // The tile without levels (its points made no surface) is not listed.
  ASSERT_EQ(listing["tiles"].size(), 2u);
  std::size_t triangles = 0;
  for (std::size_t t = 0; t < 2; ++t) {
    const Json& tile = listing["tiles"][t];
    const mesh_site::MeshTile& want = tiles_[t];
    EXPECT_EQ(tile["tile"], want.name);
    ASSERT_EQ(tile["levels"].size(), want.levels.size());
    MeshBox box;
    for (std::size_t l = 0; l < want.levels.size(); ++l) {
      const Json& level = tile["levels"][l];
      const std::string blob = util::sha256_hex(want.glbs[l]);
      EXPECT_EQ(level["level"], l);
      EXPECT_EQ(level["blob"], blob);
      EXPECT_EQ(level["url"], "/v1/sites/m1/mesh/" + want.name + "/" +
                                  std::to_string(l) + "?blob=" + blob);
      EXPECT_EQ(level["triangles"], want.levels[l].mesh.triangles());
      EXPECT_DOUBLE_EQ(level["error"].get<double>(),
                       want.levels[l].geometric_error);
      EXPECT_EQ(level["bytes"], want.glbs[l].size());
      box.add(mesh_box(want.levels[l].mesh));
    }
    triangles += want.levels[0].mesh.triangles();
    for (int a = 0; a < 3; ++a) {
      EXPECT_NEAR(tile["lo"][a].get<double>(), box.lo[a], 1e-5);
      EXPECT_NEAR(tile["hi"][a].get<double>(), box.hi[a], 1e-5);
    }
  }
  EXPECT_EQ(listing["triangles"], triangles);
  // The tiles span x 0..20 m, y 0..10 m.
  EXPECT_NEAR(listing["lo"][0].get<double>(), 0, 1e-5);
  EXPECT_NEAR(listing["hi"][0].get<double>(), 20, 1e-5);
  EXPECT_NEAR(listing["hi"][1].get<double>(), 10, 1e-5);
  // Revalidated by its ETag.
  const std::string etag = got.headers.at("etag");
  const auto again = get("/v1/sites/m1/mesh", etag);
  EXPECT_EQ(again.status, 304);
  EXPECT_TRUE(again.body.empty());
  EXPECT_EQ(get("/v1/sites/m1/mesh", "\"other\"").status, 200);
}

TEST_F(MeshRoutes, LevelIsTheStoredGlbCachedByItsBlob) {
  const Json listing = get("/v1/sites/m1/mesh").json();
  for (std::size_t t = 0; t < tiles_.size(); ++t)
    for (std::size_t l = 0; l < tiles_[t].glbs.size(); ++l) {
      const std::string url = listing["tiles"][t]["levels"][l]["url"];
      const auto got = get(url);
      ASSERT_EQ(got.status, 200) << url << ": " << got.body;
      EXPECT_EQ(got.headers.at("content-type"), "model/gltf-binary");
      EXPECT_EQ(got.body, tiles_[t].glbs[l]) << url;
      EXPECT_EQ(got.headers.at("etag"),
                "\"" + util::sha256_hex(tiles_[t].glbs[l]) + "\"");
      EXPECT_EQ(got.headers.at("cache-control"),
                "private, max-age=31536000, immutable");
    }
  // Unpinned: the current level, revalidated.
  const auto current = get("/v1/sites/m1/mesh/1_0/0");
  ASSERT_EQ(current.status, 200);
  EXPECT_EQ(current.body, tiles_[1].glbs[0]);
  EXPECT_EQ(current.headers.at("cache-control"), "private, no-cache");
  const auto held =
      get("/v1/sites/m1/mesh/1_0/0", "W/\"x\", " + current.headers.at("etag"));
  EXPECT_EQ(held.status, 304);
  EXPECT_TRUE(held.body.empty());
  // Pinned to a blob the tile no longer has: gone, fetch the listing again.
  const auto stale =
      get("/v1/sites/m1/mesh/0_0/0?blob=" + std::string(64, 'a'));
  EXPECT_EQ(stale.status, 410);
  EXPECT_NE(stale.json()["message"].get<std::string>().find("fetch the mesh"),
            std::string::npos);
}

TEST_F(MeshRoutes, ErrorsSayWhatIsMissing) {
  const auto message = [&](const std::string& target, int status) {
    const auto got = get(target);
    EXPECT_EQ(got.status, status) << target << ": " << got.body;
    return got.status == status && status != 405
               ? got.json().value("message", std::string())
               : std::string();
  };
  EXPECT_NE(message("/v1/sites/nowhere/mesh", 404).find("no site nowhere"),
            std::string::npos);
  EXPECT_NE(message("/v1/sites/nowhere/mesh/0_0/0", 404).find("nowhere"),
            std::string::npos);
  // A model whose only tile made no surface has no mesh yet.
  EXPECT_NE(message("/v1/sites/bare/mesh", 404).find("has no mesh yet"),
            std::string::npos);
  EXPECT_NE(message("/v1/sites/bare/mesh/5_5/0", 404).find("has no mesh yet"),
            std::string::npos);
  EXPECT_NE(message("/v1/sites/m1/mesh/7_7/0", 404).find("has no tile 7_7"),
            std::string::npos);
  EXPECT_NE(message("/v1/sites/m1/mesh/5_5/0", 404).find("has no tile 5_5"),
            std::string::npos);
  const std::size_t n = tiles_[0].levels.size();
  EXPECT_NE(message("/v1/sites/m1/mesh/0_0/" + std::to_string(n), 404)
                .find("has " + std::to_string(n) + " levels"),
            std::string::npos);
  EXPECT_NE(message("/v1/sites/m1/mesh/0_0/fine", 404)
                .find("/v1/sites/{id}/mesh/{tile}/{level}"),
            std::string::npos);
  message("/v1/sites/m1/mesh/0_0/0/extra", 404);
  message("/v1/sites/a%20b/mesh", 400);
  EXPECT_EQ(client_->request("DELETE", "/v1/sites/m1/mesh").status, 405);
  http::ClientOptions anonymous = client_options_;
  anonymous.token = "";
  EXPECT_EQ(http::Client(anonymous).get("/v1/sites/m1/mesh").status, 401);
  EXPECT_EQ(http::Client(anonymous).get("/v1/sites/m1/mesh/0_0/0").status, 401);
}

// A model that names a level whose blob is not stored (collected, or
// never written) is damaged data: 500 naming the level, not a retry loop.
TEST_F(MeshRoutes, ALevelNotStoredIsNamed) {
  Json attrs = store_->get("/sites/m1/model")->attrs;
  attrs["mesh_tiles"][1]["levels"][2]["blob"] = std::string(64, 'c');
  store_->put("/sites/broken/model", "model", attrs);
  store_->put("/sites/broken", "site", store_->get("/sites/m1")->attrs);
  const auto got = get("/v1/sites/broken/mesh");
  EXPECT_EQ(got.status, 500) << got.body;
  EXPECT_NE(got.body.find("level 2 of tile 1_0 (blob cccc"), std::string::npos)
      << got.body;
  EXPECT_EQ(get("/v1/sites/broken/mesh/1_0/2").status, 404);
  EXPECT_EQ(get("/v1/sites/broken/mesh/1_0/1").status, 200);
}

TEST(MeshBoxes, ReadFromTheGltfJsonAloneAndKeptPerBlob) {
  const auto store = db::Store::open(testing::fresh_sqlite_url());
  const auto tiles = mesh_site::write_mesh_site(*store, "m1");
  MeshBoxCache cache;
  const std::string hash = util::sha256_hex(tiles[0].glbs.back());
  const auto bounds = cache.get(*store, hash);
  ASSERT_TRUE(bounds);
  EXPECT_EQ(bounds->bytes,
            static_cast<std::int64_t>(tiles[0].glbs.back().size()));
  const MeshBox want = mesh_box(tiles[0].levels.back().mesh);
  EXPECT_LT((bounds->box.lo - want.lo).norm(), 1e-5);
  EXPECT_LT((bounds->box.hi - want.hi).norm(), 1e-5);
  EXPECT_EQ(cache.size(), 1u);
  EXPECT_TRUE(cache.get(*store, hash));
  EXPECT_EQ(cache.size(), 1u);
  EXPECT_FALSE(cache.get(*store, std::string(64, 'b')));
  // A blob that is not a GLB is damaged data.
  const std::string text = store->put_blob("not a mesh at all, just some text");
  EXPECT_THROW(cache.get(*store, text), util::Error);

  // The JSON chunk from a head that is long enough, else how much is needed.
  const std::string& glb = tiles[0].glbs[0];
  std::size_t need = 0;
  EXPECT_FALSE(glb_json_chunk(glb.substr(0, 24), &need));
  ASSERT_GT(need, 24u);
  const auto json = glb_json_chunk(glb.substr(0, need), &need);
  ASSERT_TRUE(json);
  EXPECT_NO_THROW(gltf_position_box(*json));
  EXPECT_THROW(glb_json_chunk("glTF but not really a GLB file", &need),
               std::runtime_error);
  EXPECT_THROW(gltf_position_box(R"({"accessors": [], "meshes": []})"),
               std::runtime_error);
}

}  // namespace
}  // namespace arscout::viewer
