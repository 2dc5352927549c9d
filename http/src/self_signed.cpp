#include "arscout/http/self_signed.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <ifaddrs.h>
#include <net/if.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <memory>
#include <set>
#include <stdexcept>

#include <openssl/bio.h>
#include <openssl/bn.h>
#include <openssl/evp.h>
#include <openssl/pem.h>
#include <openssl/x509.h>
#include <openssl/x509v3.h>

#include "arscout/util/file.h"

namespace arscout::http {
namespace {

namespace fs = std::filesystem;

constexpr int kValidDays = 397;  // the longest lifetime browsers accept
constexpr int kRenewWithinDays =
    30;  // a certificate this close to its end is remade

template <typename T, void (*Free)(T*)>
struct Deleter {
  void operator()(T* p) const { Free(p); }
};
using X509Ptr = std::unique_ptr<X509, Deleter<X509, X509_free>>;
using KeyPtr = std::unique_ptr<EVP_PKEY, Deleter<EVP_PKEY, EVP_PKEY_free>>;
using BioPtr = std::unique_ptr<BIO, Deleter<BIO, BIO_free_all>>;
using NamesPtr =
    std::unique_ptr<GENERAL_NAMES, Deleter<GENERAL_NAMES, GENERAL_NAMES_free>>;

[[noreturn]] void fail(const std::string& what) {
  throw std::runtime_error("TLS certificate: " + what);
}

bool is_ip(const std::string& name) {
  unsigned char buffer[16];
  return inet_pton(AF_INET, name.c_str(), buffer) == 1 ||
         inet_pton(AF_INET6, name.c_str(), buffer) == 1;
}

// An IP address as stored in a certificate (4 or 16 bytes), as text.
std::string ip_text(const ASN1_OCTET_STRING* ip) {
  char text[INET6_ADDRSTRLEN] = {};
  const int family = ip->length == 4 ? AF_INET : AF_INET6;
  if (ip->length != 4 && ip->length != 16) return "";
  if (!inet_ntop(family, ip->data, text, sizeof text)) return "";
  return text;
}

std::set<std::string> certificate_names(X509* cert) {
  std::set<std::string> names;
  NamesPtr sans(static_cast<GENERAL_NAMES*>(
      X509_get_ext_d2i(cert, NID_subject_alt_name, nullptr, nullptr)));
  if (!sans) return names;
  for (int i = 0; i < sk_GENERAL_NAME_num(sans.get()); ++i) {
    const GENERAL_NAME* name = sk_GENERAL_NAME_value(sans.get(), i);
    if (name->type == GEN_DNS) {
      const ASN1_IA5STRING* dns = name->d.dNSName;
      names.emplace(reinterpret_cast<const char*>(dns->data), dns->length);
    } else if (name->type == GEN_IPADD) {
      names.insert(ip_text(name->d.iPAddress));
    }
  }
  return names;
}

std::string fingerprint_of(X509* cert) {
  unsigned char md[EVP_MAX_MD_SIZE];
  unsigned int length = 0;
  if (!X509_digest(cert, EVP_sha256(), md, &length)) fail("cannot digest");
  std::string out;
  char byte[4];
  for (unsigned int i = 0; i < length; ++i) {
    std::snprintf(byte, sizeof byte, i ? ":%02X" : "%02X", md[i]);
    out += byte;
  }
  return out;
}

X509Ptr read_certificate(const std::string& path) {
  BioPtr in(BIO_new_file(path.c_str(), "r"));
  if (!in) return nullptr;
  return X509Ptr(PEM_read_bio_X509(in.get(), nullptr, nullptr, nullptr));
}

KeyPtr read_key(const std::string& path) {
  BioPtr in(BIO_new_file(path.c_str(), "r"));
  if (!in) return nullptr;
  return KeyPtr(PEM_read_bio_PrivateKey(in.get(), nullptr, nullptr, nullptr));
}

// The kept pair still serves: it parses, belongs together, names every
// name and lasts long enough.
bool still_serves(const std::string& cert_path, const std::string& key_path,
                  const std::vector<std::string>& names) {
  X509Ptr cert = read_certificate(cert_path);
  KeyPtr key = read_key(key_path);
  if (!cert || !key || X509_check_private_key(cert.get(), key.get()) != 1)
    return false;
  std::time_t horizon = std::time(nullptr) + kRenewWithinDays * 86400L;
  if (X509_cmp_time(X509_get0_notAfter(cert.get()), &horizon) <= 0)
    return false;
  const std::set<std::string> held = certificate_names(cert.get());
  return std::all_of(names.begin(), names.end(),
                     [&](const std::string& n) { return held.count(n) > 0; });
}

void add_extension(X509* cert, int nid, const std::string& value) {
  X509V3_CTX ctx;
  X509V3_set_ctx_nodb(&ctx);
  X509V3_set_ctx(&ctx, cert, cert, nullptr, nullptr, 0);
  X509_EXTENSION* ext = X509V3_EXT_conf_nid(nullptr, &ctx, nid, value.c_str());
  if (!ext) fail("cannot make the extension " + value);
  X509_add_ext(cert, ext, -1);
  X509_EXTENSION_free(ext);
}

std::string alt_names(const std::vector<std::string>& names) {
  std::string out;
  for (const std::string& n : names) {
    if (!out.empty()) out += ',';
    out += (is_ip(n) ? "IP:" : "DNS:") + n;
  }
  return out;
}

void set_identity(X509* cert, const std::vector<std::string>& names) {
  X509_set_version(cert, 2);  // v3
  std::unique_ptr<BIGNUM, Deleter<BIGNUM, BN_free>> serial(BN_new());
  BN_rand(serial.get(), 128, BN_RAND_TOP_ANY, BN_RAND_BOTTOM_ANY);
  BN_to_ASN1_INTEGER(serial.get(), X509_get_serialNumber(cert));
  X509_gmtime_adj(X509_getm_notBefore(cert), -3600);  // clocks disagree a bit
  X509_time_adj_ex(X509_getm_notAfter(cert), kValidDays, 0, nullptr);
  X509_NAME* subject = X509_get_subject_name(cert);
  const std::string common = ("arscout " + names.at(1)).substr(0, 64);
  X509_NAME_add_entry_by_txt(subject, "O", MBSTRING_UTF8,
                             reinterpret_cast<const unsigned char*>("arscout"),
                             -1, -1, 0);
  X509_NAME_add_entry_by_txt(
      subject, "CN", MBSTRING_UTF8,
      reinterpret_cast<const unsigned char*>(common.c_str()), -1, -1, 0);
  X509_set_issuer_name(cert, subject);
  // CA:TRUE so that a phone can install it as a trusted authority (Android
  // takes only those); it signs nothing but itself.
  add_extension(cert, NID_basic_constraints, "critical,CA:TRUE,pathlen:0");
  add_extension(cert, NID_key_usage, "critical,digitalSignature,keyCertSign");
  add_extension(cert, NID_ext_key_usage, "serverAuth");
  add_extension(cert, NID_subject_key_identifier, "hash");
  add_extension(cert, NID_subject_alt_name, alt_names(names));
}

// PEM text of a key or certificate.
template <typename Write>
std::string pem(Write write) {
  BioPtr out(BIO_new(BIO_s_mem()));
  if (!out || !write(out.get())) fail("cannot write PEM");
  char* data = nullptr;
  const long size = BIO_get_mem_data(out.get(), &data);
  return std::string(data, static_cast<size_t>(size));
}

SelfSignedCertificate make_certificate(const fs::path& dir,
                                       const std::vector<std::string>& names) {
  KeyPtr key(EVP_EC_gen("P-256"));
  X509Ptr cert(X509_new());
  if (!key || !cert) fail("cannot make a P-256 key");
  set_identity(cert.get(), names);
  X509_set_pubkey(cert.get(), key.get());
  if (!X509_sign(cert.get(), key.get(), EVP_sha256())) fail("cannot sign");
  fs::create_directories(dir);
  util::write_file_atomic((dir / "key.pem").string(), pem([&](BIO* b) {
                            return PEM_write_bio_PrivateKey(
                                       b, key.get(), nullptr, nullptr, 0,
                                       nullptr, nullptr) == 1;
                          }),
                          0600);
  util::write_file_atomic((dir / "cert.pem").string(), pem([&](BIO* b) {
                            return PEM_write_bio_X509(b, cert.get()) == 1;
                          }),
                          0644);
  SelfSignedCertificate out;
  out.fingerprint = fingerprint_of(cert.get());
  out.created = true;
  return out;
}

}  // namespace

SelfSignedCertificate ensure_self_signed(
    const std::string& dir, const std::vector<std::string>& names) {
  if (names.size() < 2) fail("needs at least two names (localhost and a host)");
  const fs::path folder(dir);
  const std::string cert_path = (folder / "cert.pem").string();
  const std::string key_path = (folder / "key.pem").string();
  SelfSignedCertificate out;
  if (still_serves(cert_path, key_path, names)) {
    X509Ptr cert = read_certificate(cert_path);
    out.fingerprint = fingerprint_of(cert.get());
  } else {
    out = make_certificate(folder, names);
  }
  out.cert_path = cert_path;
  out.key_path = key_path;
  X509Ptr cert = read_certificate(cert_path);
  if (!cert) fail("cannot read back " + cert_path);
  const std::set<std::string> held = certificate_names(cert.get());
  out.names.assign(held.begin(), held.end());
  return out;
}

std::vector<std::string> machine_names() {
  std::vector<std::string> names = {"localhost"};
  char host[256] = {};
  if (::gethostname(host, sizeof host - 1) == 0 && host[0])
    names.push_back(host);
  else
    names.push_back("arscout");
  names.push_back("127.0.0.1");
  names.push_back("::1");
  std::set<std::string> others;
  ifaddrs* list = nullptr;
  if (::getifaddrs(&list) == 0) {
    for (const ifaddrs* i = list; i; i = i->ifa_next) {
      if (!i->ifa_addr || !(i->ifa_flags & IFF_UP)) continue;
      char text[INET6_ADDRSTRLEN] = {};
      const int family = i->ifa_addr->sa_family;
      if (family == AF_INET) {
        const auto* a = reinterpret_cast<const sockaddr_in*>(i->ifa_addr);
        inet_ntop(AF_INET, &a->sin_addr, text, sizeof text);
      } else if (family == AF_INET6) {
        const auto* a = reinterpret_cast<const sockaddr_in6*>(i->ifa_addr);
        if (IN6_IS_ADDR_LINKLOCAL(&a->sin6_addr)) continue;
        inet_ntop(AF_INET6, &a->sin6_addr, text, sizeof text);
      }
      if (text[0]) others.insert(text);
    }
    ::freeifaddrs(list);
  }
  for (const std::string& a : others)
    if (std::find(names.begin(), names.end(), a) == names.end())
      names.push_back(a);
  return names;
}

std::string default_tls_dir() {
  if (const char* config = std::getenv("XDG_CONFIG_HOME"); config && *config)
    return (fs::path(config) / "arscout" / "tls").string();
  const char* home = std::getenv("HOME");
  return (fs::path(home && *home ? home : ".") / ".config" / "arscout" / "tls")
      .string();
}

}  // namespace arscout::http
