// The self-signed certificate of `serve --tls-self-signed`: made with the
// names asked for, kept and reused, remade when a name is new or the kept
// files do not serve; checked through OpenSSL itself, not through the
// code that wrote it.
#include "arscout/http/self_signed.h"

#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <regex>

#include <gtest/gtest.h>
#include <openssl/pem.h>
#include <openssl/x509.h>
#include <openssl/x509v3.h>

#include "test_stores.h"

namespace arscout::http {
namespace {

namespace fs = std::filesystem;

struct Parsed {
  X509* cert = nullptr;
  EVP_PKEY* key = nullptr;
  ~Parsed() {
    X509_free(cert);
    EVP_PKEY_free(key);
  }
};

void read_pair(const SelfSignedCertificate& c, Parsed* out) {
  FILE* f = std::fopen(c.cert_path.c_str(), "r");
  ASSERT_NE(f, nullptr);
  out->cert = PEM_read_X509(f, nullptr, nullptr, nullptr);
  std::fclose(f);
  f = std::fopen(c.key_path.c_str(), "r");
  ASSERT_NE(f, nullptr);
  out->key = PEM_read_PrivateKey(f, nullptr, nullptr, nullptr);
  std::fclose(f);
  ASSERT_NE(out->cert, nullptr);
  ASSERT_NE(out->key, nullptr);
}

const std::vector<std::string> kNames = {"localhost", "fieldbox", "127.0.0.1",
                                         "::1", "192.0.2.9"};

TEST(SelfSignedTest, MakesAPairForEveryNameThatOpenSslAccepts) {
  const std::string dir = testing::make_temp_dir("tls") + "/keys";
  const SelfSignedCertificate c = ensure_self_signed(dir, kNames);
  EXPECT_TRUE(c.created);
  Parsed p;
  read_pair(c, &p);
  EXPECT_EQ(X509_check_private_key(p.cert, p.key), 1);
  EXPECT_EQ(X509_check_host(p.cert, "fieldbox", 0, 0, nullptr), 1);
  EXPECT_EQ(X509_check_host(p.cert, "localhost", 0, 0, nullptr), 1);
  EXPECT_EQ(X509_check_ip_asc(p.cert, "192.0.2.9", 0), 1);
  EXPECT_EQ(X509_check_ip_asc(p.cert, "::1", 0), 1);
  EXPECT_NE(X509_check_ip_asc(p.cert, "192.0.2.10", 0), 1);
  // Self-signed: it verifies against itself as the only trusted one.
  X509_STORE* trusted = X509_STORE_new();
  X509_STORE_add_cert(trusted, p.cert);
  X509_STORE_CTX* ctx = X509_STORE_CTX_new();
  X509_STORE_CTX_init(ctx, trusted, p.cert, nullptr);
  EXPECT_EQ(X509_verify_cert(ctx), 1)
      << X509_verify_cert_error_string(X509_STORE_CTX_get_error(ctx));
  X509_STORE_CTX_free(ctx);
  X509_STORE_free(trusted);
  // Valid now, for about 397 days.
  int days = 0, seconds = 0;
  ASSERT_EQ(
      ASN1_TIME_diff(&days, &seconds, nullptr, X509_get0_notAfter(p.cert)), 1);
  EXPECT_GE(days, 396);
  EXPECT_LE(days, 397);
  // The fingerprint is the certificate's SHA-256, as browsers show it.
  unsigned char md[EVP_MAX_MD_SIZE];
  unsigned int n = 0;
  X509_digest(p.cert, EVP_sha256(), md, &n);
  char first[3];
  std::snprintf(first, sizeof first, "%02X", md[0]);
  EXPECT_TRUE(std::regex_match(c.fingerprint,
                               std::regex("([0-9A-F]{2}:){31}[0-9A-F]{2}")));
  EXPECT_EQ(c.fingerprint.substr(0, 2), first);
  // The key is for its owner only.
  struct stat st {};
  ASSERT_EQ(::stat(c.key_path.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u);
  EXPECT_EQ(c.names.size(), kNames.size());
}

TEST(SelfSignedTest, KeepsThePairUntilANameIsNewOrTheFilesAreBad) {
  const std::string dir = testing::make_temp_dir("tls");
  const SelfSignedCertificate first = ensure_self_signed(dir, kNames);
  const SelfSignedCertificate again = ensure_self_signed(dir, kNames);
  EXPECT_FALSE(again.created);
  EXPECT_EQ(again.fingerprint, first.fingerprint);
  // A subset of the names is still served by the kept one.
  EXPECT_FALSE(ensure_self_signed(dir, {"localhost", "fieldbox"}).created);
  // A new address (the machine joined another network): remade.
  std::vector<std::string> moved = kNames;
  moved.push_back("198.51.100.4");
  const SelfSignedCertificate remade = ensure_self_signed(dir, moved);
  EXPECT_TRUE(remade.created);
  EXPECT_NE(remade.fingerprint, first.fingerprint);
  // A damaged certificate file: remade, not served.
  std::ofstream(remade.cert_path) << "-----BEGIN CERTIFICATE-----\ngarbage\n";
  EXPECT_TRUE(ensure_self_signed(dir, moved).created);
  // A key that is not the certificate's: remade.
  const std::string other = testing::make_temp_dir("tls-other");
  const SelfSignedCertificate foreign = ensure_self_signed(other, kNames);
  fs::copy_file(foreign.key_path, dir + "/key.pem",
                fs::copy_options::overwrite_existing);
  EXPECT_TRUE(ensure_self_signed(dir, moved).created);
  EXPECT_FALSE(fs::exists(dir + "/key.pem.part"));
}

TEST(SelfSignedTest, MachineNamesIncludeTheLoopbackNames) {
  const std::vector<std::string> names = machine_names();
  ASSERT_GE(names.size(), 4u);
  EXPECT_EQ(names[0], "localhost");
  EXPECT_NE(std::find(names.begin(), names.end(), "127.0.0.1"), names.end());
  for (const std::string& n : names)
    EXPECT_EQ(n.rfind("fe80", 0), std::string::npos) << n;
}

}  // namespace
}  // namespace arscout::http
