// A small HTTP(S) client for the arscout API, used by the scout client, the
// planner commands and tests. One keep-alive connection per Client; not
// thread-safe (use one Client per thread).
#pragma once

#include <chrono>
#include <map>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

namespace arscout::http {

struct ClientOptions {
  std::string server;  // "http://host:port" or "https://host:port"
  std::string token;   // sent as "Authorization: Bearer TOKEN" when not empty
  std::chrono::milliseconds timeout{60000};  // per request, connect included
  bool verify_tls = true;
  // Extra CA certificate (PEM) to trust. Initialised, so that the
  // {server, token} initialisers the tests use are not -Wextra warnings.
  std::string ca_file{};
};

struct HttpResult {
  int status = 0;
  std::map<std::string, std::string> headers;  // keys lower-case
  std::string body;
  nlohmann::json json() const;  // the body parsed; throws on invalid JSON
};

// The request could not be completed (connection refused or reset, timeout,
// TLS failure): it may or may not have reached the server. Worth retrying.
class NetworkError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class Client {
 public:
  explicit Client(ClientOptions options);
  ~Client();
  Client(const Client&) = delete;
  Client& operator=(const Client&) = delete;

  // Sends one request; any HTTP status is a result, not an error. Reconnects
  // if the kept-alive connection was closed. Throws NetworkError.
  HttpResult request(
      const std::string& method, const std::string& target,
      const std::string& body = "",
      const std::vector<std::pair<std::string, std::string>>& headers = {});
  HttpResult get(const std::string& target) { return request("GET", target); }

 private:
  struct Impl;
  Impl* impl_;
};

}  // namespace arscout::http
