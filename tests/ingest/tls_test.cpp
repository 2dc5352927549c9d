// HTTPS and WSS with a certificate made for the test (openssl CLI).
#include <cstdlib>

#include <gtest/gtest.h>

#include "arscout/db/store.h"
#include "arscout/http/change_stream.h"
#include "arscout/http/client.h"
#include "arscout/ingest/auth.h"
#include "arscout/ingest/server.h"
#include "test_stores.h"

namespace arscout::ingest {

using http::ChangeStream;
using http::Client;
using http::ClientOptions;
using http::NetworkError;
namespace {

using namespace std::chrono_literals;

TEST(TlsTest, ServesHttpsAndWssWithATrustedCertificate) {
  std::string dir = testing::make_temp_dir("tls");
  std::string cert = dir + "/cert.pem", key = dir + "/key.pem";
  std::string cmd =
      "openssl req -x509 -newkey rsa:2048 -nodes -days 1 -subj /CN=localhost "
      "-addext subjectAltName=IP:127.0.0.1,DNS:localhost -keyout " +
      key + " -out " + cert + " >/dev/null 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << "openssl could not make a cert";
  auto store = db::Store::open(testing::fresh_sqlite_url());
  std::string token = create_token(*store, Role::kPlanner, "pat");
  ServerOptions options;
  options.port = 0;
  options.tls_cert = cert;
  options.tls_key = key;
  Server server(*store, options);
  server.start();
  ASSERT_TRUE(server.tls());

  ClientOptions trusted;
  trusted.server = "https://127.0.0.1:" + std::to_string(server.port());
  trusted.token = token;
  trusted.ca_file = cert;
  Client client(trusted);
  EXPECT_EQ(client.get("/healthz").status, 200);
  store->put("/sites/s", "site", nlohmann::json::object());
  EXPECT_EQ(client.get("/v1/docs/sites/s").status, 200);

  ChangeStream stream(trusted, 0, "/sites/*");
  auto change = stream.next(5s);
  ASSERT_TRUE(change);
  EXPECT_EQ((*change)["path"], "/sites/s");

  // Without trusting the certificate, verification fails.
  ClientOptions untrusted = trusted;
  untrusted.ca_file.clear();
  Client stranger(untrusted);
  EXPECT_THROW(stranger.get("/healthz"), NetworkError);
  // Plain HTTP to the HTTPS port gets no answer.
  ClientOptions plain = trusted;
  plain.server = "http://127.0.0.1:" + std::to_string(server.port());
  Client wrong(plain);
  EXPECT_THROW(wrong.get("/healthz"), NetworkError);
}

TEST(TlsTest, MissingCertificateFilesAreAClearStartError) {
  auto store = db::Store::open(testing::fresh_sqlite_url());
  ServerOptions options;
  options.port = 0;
  options.tls_cert = "/nonexistent/cert.pem";
  options.tls_key = "/nonexistent/key.pem";
  Server server(*store, options);
  try {
    server.start();
    FAIL() << "started without its certificate";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("certificate"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace arscout::ingest
