// A self-signed TLS certificate for this machine, made once and kept, so
// that phones on the same network can reach `arscout serve` over HTTPS
// (a phone browser gives a page its camera and GPS only over HTTPS).
//
// Contract:
// - ensure_self_signed() keeps `key.pem` (mode 0600) and `cert.pem` in a
//   folder. It reuses them while the certificate names every requested
//   name and stays valid for at least 30 more days; otherwise it makes a
//   new ECDSA P-256 key and a certificate valid for 397 days (the longest
//   browsers accept) whose subject alternative names are the names, DNS
//   names and IP addresses alike. Files are written atomically: a crash
//   leaves the old pair or the new one.
// - Throws std::runtime_error naming the file or the OpenSSL step that
//   failed.
#pragma once

#include <string>
#include <vector>

namespace arscout::http {

struct SelfSignedCertificate {
  std::string cert_path;
  std::string key_path;
  // SHA-256 of the certificate's DER bytes, "AB:CD:..." (what browsers show).
  std::string fingerprint;
  std::vector<std::string> names;  // its subject alternative names
  bool created = false;            // false when an existing one was reused
};

SelfSignedCertificate ensure_self_signed(const std::string& dir,
                                         const std::vector<std::string>& names);

// The names this machine answers to: "localhost", its host name, 127.0.0.1,
// ::1 and the address of every interface that is up (IPv6 link-local ones
// left out: a browser cannot use them in a URL without a zone).
std::vector<std::string> machine_names();

// Where `serve --tls-self-signed` keeps the pair unless told:
// $XDG_CONFIG_HOME/arscout/tls, else $HOME/.config/arscout/tls.
std::string default_tls_dir();

}  // namespace arscout::http
