// The arscout HTTP(S) server: the v1 API of docs/api.md over one store.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

#include "arscout/db/store.h"

namespace arscout::ingest {

struct ServerOptions {
  std::string host = "127.0.0.1";
  std::uint16_t port = 8080;  // 0: any free port (see Server::port)
  std::string tls_cert;       // PEM files; both set: HTTPS only
  std::string tls_key;
  std::size_t max_body_bytes = 64u << 20;
  std::size_t max_header_bytes = 16u << 10;
  // A client must send a whole request header within this time (defeats
  // slow-header attacks); the body gets 30 s + 1 s per 64 KiB.
  std::chrono::seconds header_timeout{15};
  std::chrono::seconds idle_timeout{60};  // between keep-alive requests
  int io_threads = 2;
  // Handlers (store access, image decoding, long-polls) run here, off the
  // network threads; a long-poll holds one for up to 60 s.
  int worker_threads = 32;
};

class Server {
 public:
  Server(db::Store& store, ServerOptions options);
  ~Server();  // stops
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  // Binds, listens and starts serving on background threads. Throws
  // std::runtime_error when the address cannot be bound or TLS files load.
  void start();
  // Stops accepting, closes connections and joins the threads.
  void stop();
  std::uint16_t port() const;
  bool tls() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace arscout::ingest
