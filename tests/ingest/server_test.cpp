// The HTTP API over a real store on both backends: bad input, auth rules,
// idempotent uploads and the WebSocket feed (docs/api.md).
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <thread>

#include <gtest/gtest.h>

#include "arscout/db/store.h"
#include "arscout/http/change_stream.h"
#include "arscout/http/client.h"
#include "arscout/ingest/auth.h"
#include "arscout/ingest/server.h"
#include "raw_http.h"
#include "test_stores.h"

namespace arscout::ingest {

using http::ChangeStream;
using http::Client;
using http::ClientOptions;
using http::HttpResult;
using http::NetworkError;
namespace {

using namespace std::chrono_literals;
using Headers = std::vector<std::pair<std::string, std::string>>;
using Json = nlohmann::json;

// A small, valid, distinct JPEG, encoded here.
std::string jpeg_bytes(int seed) {
  cv::Mat image(120, 160, CV_8UC3, cv::Scalar(seed * 37 % 255, 90, 200));
  cv::circle(image, {40 + seed % 80, 60}, 20, cv::Scalar(0, 0, 0), -1);
  std::vector<uchar> out;
  cv::imencode(".jpg", image, out);
  return std::string(out.begin(), out.end());
}

// A valid small JPEG whose frame header (SOF0) declares width x height: a
// decompression bomb, 2 KB that would decode to gigabytes.
std::string jpeg_declaring(int width, int height) {
  std::string bytes = jpeg_bytes(7);
  std::size_t sof = bytes.find("\xFF\xC0");
  if (sof == std::string::npos) return bytes;
  bytes[sof + 5] = static_cast<char>(height >> 8);
  bytes[sof + 6] = static_cast<char>(height & 0xFF);
  bytes[sof + 7] = static_cast<char>(width >> 8);
  bytes[sof + 8] = static_cast<char>(width & 0xFF);
  return bytes;
}

std::string metadata(const std::string& id, double lat = 47.07,
                     double lon = 15.44) {
  return Json{{"capture_id", id},
              {"gps", {{"lat", lat}, {"lon", lon}, {"h_acc", 3.0}}}}
      .dump();
}

using testing::raw_exchange;

class ServerTest : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    ARSCOUT_FRESH_STORE_OR_SKIP(url_, GetParam());
    store_ = db::Store::open(url_);
    alice_ = create_token(*store_, Role::kScout, "alice");
    bob_ = create_token(*store_, Role::kScout, "bob");
    planner_ = create_token(*store_, Role::kPlanner, "pat");
    admin_ = create_token(*store_, Role::kAdmin, "root");
    ServerOptions options;
    options.port = 0;
    options.header_timeout = 3s;  // keeps the slow-client case short
    server_ = std::make_unique<Server>(*store_, options);
    server_->start();
  }

  ClientOptions as(const std::string& token) {
    ClientOptions o;
    o.server = "http://127.0.0.1:" + std::to_string(server_->port());
    o.token = token;
    return o;
  }

  HttpResult upload(const std::string& token, const std::string& body,
                    const std::string& meta) {
    Client c(as(token));
    return c.request(
        "POST", "/v1/captures", body,
        {{"Content-Type", "image/jpeg"}, {"X-Capture-Metadata", meta}});
  }

  // The change log and document count, to show a request changed nothing.
  std::string snapshot() {
    std::string out = std::to_string(store_->stats().documents) + "\n";
    for (const auto& c : store_->changes(0, "/**", 1000000))
      out += to_json(c).dump() + "\n";
    return out;
  }

  std::string url_;
  std::unique_ptr<db::Store> store_;
  std::unique_ptr<Server> server_;
  std::string alice_, bob_, planner_, admin_;
};

TEST_P(ServerTest, UploadStoresOneCaptureAndRetriesAreReplays) {
  std::string image = jpeg_bytes(1);
  HttpResult first = upload(alice_, image, metadata("1"));
  ASSERT_EQ(first.status, 201) << first.body;
  Json doc = first.json();
  EXPECT_EQ(doc["path"], "/captures/alice.1");  // under the scout's name
  EXPECT_EQ(doc["attrs"]["scout"], "alice");
  EXPECT_EQ(doc["attrs"]["gps"]["source"], "request");
  EXPECT_EQ(doc["attrs"]["width"], 160);
  EXPECT_EQ(doc["attrs"]["status"], "stored");
  EXPECT_EQ(store_->get_blob(doc["blobs"]["image"].get<std::string>()), image);

  std::string before = snapshot();
  HttpResult again = upload(alice_, image, metadata("1"));
  EXPECT_EQ(again.status, 201);
  EXPECT_EQ(again.headers["idempotent-replay"], "true");
  EXPECT_EQ(again.json()["seq"], doc["seq"]);
  // The id the server answered is the same capture.
  HttpResult by_stored_id = upload(alice_, image, metadata("alice.1"));
  EXPECT_EQ(by_stored_id.headers["idempotent-replay"], "true");
  EXPECT_EQ(by_stored_id.json()["path"], "/captures/alice.1");
  EXPECT_EQ(snapshot(), before);

  HttpResult other = upload(alice_, jpeg_bytes(2), metadata("1"));
  EXPECT_EQ(other.status, 409) << other.body;
  EXPECT_EQ(snapshot(), before);
  // Bob's "1", and even his "alice.1", are his own captures.
  for (const char* id : {"1", "alice.1"}) {
    HttpResult bobs = upload(bob_, image, metadata(id));
    EXPECT_EQ(bobs.status, 201) << bobs.body;
    EXPECT_EQ(bobs.json()["path"], std::string("/captures/bob.") + id);
  }
}

TEST_P(ServerTest, CaptureWithoutGpsNeedsGpsAndMultipartWorks) {
  std::string image = jpeg_bytes(3);
  std::string boundary = "XyZ123";
  std::string body = "--" + boundary +
                     "\r\nContent-Disposition: form-data; name=\"metadata\"\r\n"
                     "Content-Type: application/json\r\n\r\n" +
                     Json{{"capture_id", "alice-mp"}}.dump() + "\r\n--" +
                     boundary +
                     "\r\nContent-Disposition: form-data; name=\"image\"; "
                     "filename=\"a.jpg\"\r\nContent-Type: image/jpeg\r\n\r\n" +
                     image + "\r\n--" + boundary + "--\r\n";
  Client c(as(alice_));
  HttpResult r = c.request(
      "POST", "/v1/captures", body,
      {{"Content-Type", "multipart/form-data; boundary=" + boundary}});
  ASSERT_EQ(r.status, 201) << r.body;
  EXPECT_EQ(r.json()["attrs"]["status"], "needs-gps");
  EXPECT_FALSE(r.json()["attrs"].contains("gps"));
  EXPECT_EQ(store_->get_blob(r.json()["blobs"]["image"].get<std::string>()),
            image);
}

TEST_P(ServerTest, WithdrawIsForTheOwnScoutOrAnAdmin) {
  ASSERT_EQ(upload(alice_, jpeg_bytes(4), metadata("w")).status, 201);
  Client bob(as(bob_)), alice(as(alice_)), planner(as(planner_));
  EXPECT_EQ(bob.request("DELETE", "/v1/captures/alice.w").status, 403);
  EXPECT_EQ(planner.request("DELETE", "/v1/captures/alice.w").status, 403);
  HttpResult ok = alice.request("DELETE", "/v1/captures/alice.w");
  ASSERT_EQ(ok.status, 200) << ok.body;
  EXPECT_EQ(ok.json()["attrs"]["status"], "withdrawn");
  EXPECT_EQ(planner.get("/v1/docs/captures/alice.w").status, 200);
}

struct BadCase {
  std::string name;
  std::string method, target, token_role, body;
  Headers headers;
  int status;
  std::string says;
};

TEST_P(ServerTest, BadInputGetsItsOwnStatusAndChangesNothing) {
  ASSERT_EQ(upload(alice_, jpeg_bytes(5), metadata("alice-x")).status, 201);
  store_->put("/sites/s1", "site", Json{{"gps", {{"lat", 1.0}, {"lon", 2.0}}}});
  const std::string image = jpeg_bytes(6);
  const std::string jpeg_head = "image/jpeg";
  std::vector<BadCase> cases = {
      {"zero-byte body", "POST", "/v1/captures", "alice", "", {}, 422, "empty"},
      {"truncated JPEG",
       "POST",
       "/v1/captures",
       "alice",
       image.substr(0, image.size() / 2),
       {},
       422,
       "truncated"},
      {"a JPEG declaring 30000 x 30000 pixels (900 MP)",
       "POST",
       "/v1/captures",
       "alice",
       jpeg_declaring(30000, 30000),
       {},
       422,
       "megapixels accepted"},
      {"a PDF",
       "POST",
       "/v1/captures",
       "alice",
       "%PDF-1.4\n1 0 obj\n",
       {{"Content-Type", "application/pdf"}},
       422,
       "not a JPEG or PNG"},
      {"latitude 200",
       "POST",
       "/v1/captures",
       "alice",
       image,
       {{"X-Capture-Metadata", metadata("c-lat", 200, 10)}},
       422,
       "gps.lat"},
      {"NaN altitude",
       "POST",
       "/v1/captures",
       "alice",
       image,
       {{"X-Capture-Metadata", R"({"gps":{"lat":1,"lon":2,"alt":"NaN"}})"}},
       422,
       "gps.alt"},
      {"negative accuracy",
       "POST",
       "/v1/captures",
       "alice",
       image,
       {{"X-Capture-Metadata", R"({"gps":{"lat":1,"lon":2,"h_acc":-3}})"}},
       422,
       "h_acc"},
      {"malformed JSON metadata",
       "POST",
       "/v1/captures",
       "alice",
       image,
       {{"X-Capture-Metadata", R"({"gps": {"lat": 1,)"}},
       400,
       "at byte"},
      {"'..' as capture id",
       "POST",
       "/v1/captures",
       "alice",
       image,
       {{"X-Capture-Metadata", R"({"capture_id":".."})"}},
       400,
       "'..'"},
      {"multipart without image",
       "POST",
       "/v1/captures",
       "alice",
       "--b\r\nContent-Disposition: form-data; name=\"metadata\"\r\n\r\n{}"
       "\r\n--b--\r\n",
       {{"Content-Type", "multipart/form-data; boundary=b"}},
       422,
       "image"},
      {"capture id of another upload",
       "POST",
       "/v1/captures",
       "alice",
       image,
       {{"X-Capture-Metadata", metadata("alice-x")}},
       409,
       "different upload"},
      {"planner uploads",
       "POST",
       "/v1/captures",
       "planner",
       image,
       {},
       403,
       "planners"},
      {"wrong token",
       "GET",
       "/v1/docs/sites/s1",
       "wrong",
       "",
       {},
       401,
       "no such token"},
      {"no token", "GET", "/v1/docs/sites/s1", "", "", {}, 401, "required"},
      {"unknown capture on DELETE",
       "DELETE",
       "/v1/captures/never-was",
       "alice",
       "",
       {},
       404,
       "no capture"},
      {"another scout's capture",
       "DELETE",
       "/v1/captures/alice.alice-x",
       "bob",
       "",
       {},
       403,
       "own scout"},
      {"'..' in a document path",
       "GET",
       "/v1/docs/sites/../auth",
       "alice",
       "",
       {},
       400,
       "'..'"},
      {"encoded '..' in a path",
       "GET",
       "/v1/docs/sites/%2e%2e/x",
       "alice",
       "",
       {},
       400,
       "'..'"},
      {"bad percent-encoding",
       "GET",
       "/v1/docs/sites/%zz",
       "alice",
       "",
       {},
       400,
       "percent"},
      {"unknown route", "GET", "/v1/nowhere", "alice", "", {}, 404, "no route"},
      {"wrong method", "PATCH", "/v1/changes", "alice", "", {}, 405, "GET"},
      {"scout writes a document",
       "PUT",
       "/v1/docs/sites/s1",
       "alice",
       R"({"kind":"site","attrs":{}})",
       {},
       403,
       "admin"},
      {"stale If-Match",
       "PUT",
       "/v1/docs/sites/s1",
       "admin",
       R"({"kind":"site","attrs":{}})",
       {{"If-Match", "\"9\""}},
       409,
       "current is version 1"},
      {"malformed document JSON",
       "PUT",
       "/v1/docs/sites/s2",
       "admin",
       R"({"kind":)",
       {},
       400,
       "at byte"},
      // Found with tests/fuzz: the first was answered 500 (the parser's
      // out_of_range escaped), the second crashed the server (copying the
      // attributes recursed until a worker's stack overflowed).
      {"a number beyond a double's range",
       "PUT",
       "/v1/docs/sites/s2",
       "admin",
       R"({"kind":"site","attrs":{"x":1e400}})",
       {},
       400,
       "number overflow"},
      {"JSON nested 100000 deep",
       "PUT",
       "/v1/docs/sites/s2",
       "admin",
       R"({"kind":"site","attrs":{"x":)" + std::string(100000, '[') +
           std::string(100000, ']') + "}}",
       {},
       400,
       "nested deeper than 512"},
      // Also found with tests/fuzz: error messages quote what the client
      // sent, and a byte that is not UTF-8 made the error response throw:
      // answered 500, or from a store error it escaped the API and ended
      // the server.
      {"malformed JSON with a byte that is not UTF-8",
       "PUT",
       "/v1/cameras/cam2",
       "alice",
       "{\"\x9a\":1}",
       {},
       400,
       "at byte"},
      {"a path with a byte that is not UTF-8",
       "GET",
       "/v1/docs/sites/%A4",
       "alice",
       "",
       {},
       400,
       "byte 164"},
      {"tokens are admin-only",
       "GET",
       "/v1/docs/auth/tokens",
       "planner",
       "",
       {},
       403,
       "admins"},
      {"bad since",
       "GET",
       "/v1/changes?since=abc",
       "alice",
       "",
       {},
       400,
       "since"},
      // The store's invalid_argument, 422 as on every route (docs/api.md).
      {"bad blob hash", "GET", "/v1/blobs/xyz", "alice", "", {}, 422, "hex"},
      {"unknown blob",
       "GET",
       "/v1/blobs/" + std::string(64, 'a'),
       "alice",
       "",
       {},
       404,
       "no blob"},
      {"bad near",
       "GET",
       "/v1/sites?near=north",
       "alice",
       "",
       {},
       400,
       "LAT,LON"},
      {"camera with negative focal length",
       "PUT",
       "/v1/cameras/cam1",
       "alice",
       R"({"fx":-1,"fy":800,"cx":320,"cy":240,"width":640,"height":480,)"
       R"("source":"calibrated"})",
       {},
       422,
       "fx"},
  };
  std::map<std::string, std::string> tokens = {{"alice", alice_},
                                               {"bob", bob_},
                                               {"planner", planner_},
                                               {"admin", admin_},
                                               {"wrong", "ars_not_a_token"},
                                               {"", ""}};
  const std::string before = snapshot();
  for (const BadCase& c : cases) {
    Client client(as(tokens.at(c.token_role)));
    HttpResult r = client.request(c.method, c.target, c.body, c.headers);
    EXPECT_EQ(r.status, c.status) << c.name << ": " << r.body;
    EXPECT_NE(r.body.find(c.says), std::string::npos)
        << c.name << ": " << r.body;
    EXPECT_EQ(client.get("/healthz").status, 200) << "after " << c.name;
  }
  EXPECT_EQ(snapshot(), before);
}

TEST_P(ServerTest, ProtocolAbuseIsRefusedAndTheServerKeepsServing) {
  const std::string before = snapshot();
  const std::uint16_t port = server_->port();
  // A 100 MB body is refused from its Content-Length, without reading it.
  std::string huge = raw_exchange(
      port, "POST /v1/captures HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer " +
                alice_ + "\r\nContent-Length: 104857600\r\n\r\n");
  EXPECT_NE(huge.find("413"), std::string::npos) << huge;
  // Headers over 16 KiB.
  std::string big_header =
      raw_exchange(port, "GET /healthz HTTP/1.1\r\nHost: x\r\nX-Pad: " +
                             std::string(20000, 'a') + "\r\n\r\n");
  EXPECT_NE(big_header.find("431"), std::string::npos) << big_header;
  // Not HTTP at all: the connection is dropped.
  EXPECT_EQ(raw_exchange(port, "\x16\x03\x01 hello\r\n\r\n"), "");
  // One byte a second never completes a header within the 3 s allowed.
  auto start = std::chrono::steady_clock::now();
  std::string slow =
      raw_exchange(port, "GET /healthz HTTP/1.1\r\nHost: x\r\n\r\n", 1000ms);
  auto took = std::chrono::steady_clock::now() - start;
  EXPECT_EQ(slow.find("200 OK"), std::string::npos) << slow;
  EXPECT_LT(took, 10s);
  Client c(as(alice_));
  EXPECT_EQ(c.get("/healthz").status, 200);
  EXPECT_EQ(snapshot(), before);
}

TEST_P(ServerTest, AnswersExpectContinueBeforeTheBodyIsSent) {
  const std::string image = jpeg_bytes(9);
  int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(server_->port());
  inet_pton(AF_INET, "127.0.0.1", &addr.sin_addr);
  ASSERT_EQ(connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
  timeval tv{5, 0};
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  std::string head =
      "POST /v1/captures HTTP/1.1\r\nHost: x\r\n"
      "Authorization: Bearer " +
      alice_ + "\r\nExpect: 100-continue\r\nContent-Length: " +
      std::to_string(image.size()) + "\r\nConnection: close\r\n\r\n";
  send(fd, head.data(), head.size(), MSG_NOSIGNAL);
  char buf[4096];
  ssize_t n = recv(fd, buf, sizeof buf, 0);  // before any body byte is sent
  ASSERT_GT(n, 0) << "no interim answer";
  EXPECT_EQ(std::string(buf, n).rfind("HTTP/1.1 100 Continue", 0), 0u);
  send(fd, image.data(), image.size(), MSG_NOSIGNAL);
  std::string reply;
  while ((n = recv(fd, buf, sizeof buf, 0)) > 0) reply.append(buf, n);
  close(fd);
  EXPECT_EQ(reply.rfind("HTTP/1.1 201", 0), 0u) << reply;
}

TEST_P(ServerTest, DocumentsCarryVersionsAsEtags) {
  Client admin(as(admin_)), planner(as(planner_));
  HttpResult created = admin.request("PUT", "/v1/docs/sites/s9",
                                     R"({"kind":"site","attrs":{"a":1}})",
                                     {{"If-None-Match", "*"}});
  ASSERT_EQ(created.status, 201) << created.body;
  EXPECT_EQ(created.headers["etag"], "\"1\"");
  HttpResult patched = admin.request("PATCH", "/v1/docs/sites/s9", R"({"b":2})",
                                     {{"If-Match", "\"1\""}});
  ASSERT_EQ(patched.status, 200) << patched.body;
  EXPECT_EQ(patched.headers["etag"], "\"2\"");
  HttpResult got = planner.get("/v1/docs/sites/s9");
  EXPECT_EQ(got.json()["attrs"], (Json{{"a", 1}, {"b", 2}}));
  HttpResult tree = planner.get("/v1/docs/sites?depth=1");
  EXPECT_EQ(tree.json()["documents"].size(), 1u);
  EXPECT_EQ(
      admin.request("DELETE", "/v1/docs/sites/s9", "", {{"If-Match", "\"1\""}})
          .status,
      409);
  EXPECT_EQ(admin.request("DELETE", "/v1/docs/sites/s9").status, 200);
  EXPECT_EQ(planner.get("/v1/docs/sites/s9").status, 404);
}

TEST_P(ServerTest, BlobsServeRangesWithTheirContentType) {
  std::string image = jpeg_bytes(7);
  HttpResult up = upload(alice_, image, metadata("alice-b"));
  ASSERT_EQ(up.status, 201);
  std::string hash = up.json()["blobs"]["image"];
  Client c(as(planner_));
  HttpResult whole = c.get("/v1/blobs/" + hash);
  EXPECT_EQ(whole.status, 200);
  EXPECT_EQ(whole.headers["content-type"], "image/jpeg");
  EXPECT_EQ(whole.body, image);
  HttpResult part =
      c.request("GET", "/v1/blobs/" + hash, "", {{"Range", "bytes=10-19"}});
  EXPECT_EQ(part.status, 206);
  EXPECT_EQ(part.body, image.substr(10, 10));
  EXPECT_EQ(part.headers["content-range"],
            "bytes 10-19/" + std::to_string(image.size()));
  HttpResult tail =
      c.request("GET", "/v1/blobs/" + hash, "", {{"Range", "bytes=-5"}});
  EXPECT_EQ(tail.body, image.substr(image.size() - 5));
  EXPECT_EQ(
      c.request("GET", "/v1/blobs/" + hash, "", {{"Range", "bytes=999999-"}})
          .status,
      416);
}

TEST_P(ServerTest, SitesNearAPlace) {
  store_->put("/sites/graz", "site",
              Json{{"gps", {{"lat", 47.07}, {"lon", 15.44}}}});
  store_->put("/sites/lund", "site",
              Json{{"gps", {{"lat", 55.7}, {"lon", 13.19}}}});
  Client c(as(planner_));
  HttpResult near = c.get("/v1/sites?near=47.0701,15.4401&radius=500");
  ASSERT_EQ(near.status, 200) << near.body;
  ASSERT_EQ(near.json()["sites"].size(), 1u);
  EXPECT_EQ(near.json()["sites"][0]["path"], "/sites/graz");
  EXPECT_EQ(c.get("/v1/sites").json()["sites"].size(), 2u);

  // For web maps: GeoJSON, [longitude, latitude, height]; the same filter.
  store_->put("/sites/new", "site", Json{{"name", "no fix yet"}});
  HttpResult map = c.get("/v1/sites?format=geojson&near=47.0701,15.4401");
  ASSERT_EQ(map.status, 200) << map.body;
  EXPECT_EQ(map.headers["content-type"], "application/geo+json");
  const Json collection = map.json();
  EXPECT_EQ(collection["type"], "FeatureCollection");
  ASSERT_EQ(collection["features"].size(), 1u);
  const Json& graz = collection["features"][0];
  EXPECT_EQ(graz["id"], "graz");
  EXPECT_EQ(graz["geometry"]["coordinates"][0], 15.44);
  EXPECT_EQ(graz["geometry"]["coordinates"][1], 47.07);
  const Json all = c.get("/v1/sites?format=geojson").json();
  ASSERT_EQ(all["features"].size(), 3u);
  for (const Json& f : all["features"]) {
    if (f["id"] == "new") {
      EXPECT_TRUE(f["geometry"].is_null());
    }
  }
  EXPECT_EQ(c.get("/v1/sites?format=kml").status, 400);
}

TEST_P(ServerTest, LongPollWaitsForTheNextChange) {
  std::int64_t head = store_->last_seq();
  std::thread writer([&] {
    std::this_thread::sleep_for(300ms);
    store_->put("/sites/late", "site", Json::object());
  });
  Client c(as(planner_));
  auto start = std::chrono::steady_clock::now();
  HttpResult r = c.get("/v1/changes?since=" + std::to_string(head) +
                       "&pattern=/sites/*&wait=10");
  writer.join();
  ASSERT_EQ(r.status, 200);
  ASSERT_EQ(r.json()["changes"].size(), 1u);
  EXPECT_EQ(r.json()["changes"][0]["path"], "/sites/late");
  EXPECT_LT(std::chrono::steady_clock::now() - start, 5s);
}

TEST_P(ServerTest, WebSocketDeliversEveryLaterChangeInOrderAcrossReconnects) {
  for (int i = 0; i < 3; ++i)
    store_->put("/sites/old" + std::to_string(i), "site", Json::object());
  const std::int64_t n = store_->last_seq();
  std::vector<std::int64_t> seen;
  {
    ChangeStream stream(as(planner_), n, "/sites/**");
    for (int i = 0; i < 5; ++i)
      store_->put("/sites/a" + std::to_string(i), "site", Json::object());
    store_->put("/captures/ignored", "capture", Json::object());
    while (seen.size() < 3) {
      auto change = stream.next(5s);
      ASSERT_TRUE(change) << "only " << seen.size() << " changes arrived";
      seen.push_back((*change)["seq"]);
    }
  }  // disconnect after 3 of 5
  for (int i = 5; i < 8; ++i)
    store_->put("/sites/a" + std::to_string(i), "site", Json::object());
  ChangeStream resumed(as(planner_), seen.back(), "/sites/**");
  while (seen.size() < 8) {
    auto change = resumed.next(5s);
    ASSERT_TRUE(change) << "only " << seen.size() << " changes arrived";
    EXPECT_NE((*change)["path"], "/captures/ignored");
    seen.push_back((*change)["seq"]);
  }
  auto log = store_->changes(n, "/sites/**");
  ASSERT_EQ(log.size(), 8u);
  for (std::size_t i = 0; i < log.size(); ++i) EXPECT_EQ(seen[i], log[i].seq);
  EXPECT_FALSE(resumed.next(200ms));
  EXPECT_THROW(ChangeStream(as("ars_bogus"), 0), NetworkError);
}

TEST_P(ServerTest, MetricsCountRequestsUploadsAndConnections) {
  ASSERT_EQ(upload(alice_, jpeg_bytes(8), metadata("alice-m")).status, 201);
  Client c(as(planner_));
  EXPECT_EQ(c.get("/v1/docs/nothing/here").status, 404);
  HttpResult m = c.get("/metrics");  // no token needed, but one is fine
  ASSERT_EQ(m.status, 200);
  EXPECT_EQ(m.headers["content-type"], "text/plain; version=0.0.4");
  EXPECT_NE(
      m.body.find(
          R"(arscout_http_requests_total{route="POST /v1/captures",status="201"} 1)"),
      std::string::npos)
      << m.body;
  EXPECT_NE(m.body.find(R"(route="GET /v1/docs/*",status="404"} 1)"),
            std::string::npos);
  EXPECT_NE(
      m.body.find(
          R"(arscout_http_request_duration_seconds_count{route="POST /v1/captures"} 1)"),
      std::string::npos);
  EXPECT_NE(m.body.find("arscout_upload_bytes_total " +
                        std::to_string(jpeg_bytes(8).size())),
            std::string::npos);
  // This client's connection at least; the upload's may not be reaped yet.
  auto at = m.body.find("\narscout_active_connections ");
  ASSERT_NE(at, std::string::npos);
  EXPECT_GE(std::stoi(m.body.substr(at + 28)), 1);
}

INSTANTIATE_TEST_SUITE_P(Backends, ServerTest,
                         ::testing::Values("sqlite", "postgresql"),
                         [](const auto& info) { return info.param; });

}  // namespace
}  // namespace arscout::ingest
