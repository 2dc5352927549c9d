// One accepted connection's HTTP/1.1 session (beast_session.cpp), served
// until it closes. Apart from the listener (beast_server.cpp): the session
// instantiates Beast's templates, the listener only Asio's acceptor.
#pragma once

#include <utility>  // before Asio, for C++20

#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/ssl/context.hpp>
#include <boost/asio/thread_pool.hpp>
#include <optional>

#include "arscout/http/byte_budget.h"
#include "arscout/http/keyed_limit.h"
#include "arscout/http/server.h"

namespace arscout::http {

// What every session of one server shares.
struct SessionContext {
  Service& service;
  const ServerLimits& limits;
  boost::asio::thread_pool& workers;
  // The requests Service::runs_long names (exports) run here, so that a
  // crowd of them queues among themselves and leaves `workers` to
  // everything else.
  boost::asio::thread_pool& long_workers;
  // The operations paths (/healthz, /metrics) are answered here, so that a
  // monitor never waits behind a crowd of requests queued for `workers`.
  boost::asio::thread_pool& operations_workers;
  // The pieces of streamed bodies are read here, at low priority: bulk
  // transfers take the cores only when the rest of the server leaves them.
  boost::asio::thread_pool& piece_workers;
  ByteBudget& send_budget;  // pieces of streamed bodies in flight
  KeyedLimit& bodies;       // request bodies being read, per token
  ByteBudget& body_budget;  // their bytes, by Content-Length
  KeyedLimit& streams;      // open long-polls and streams, per token
};

// Serves `socket` (over TLS with `tls`, plain HTTP when it is null) until
// the connection closes, holding its `connection` slot until then. An
// `operations_only` connection (one past its address's cap) is answered
// once, and only for the operations paths (503 otherwise), so that a
// monitor sharing an address with a crowd of clients still sees the server;
// it must send its header within 2 s.
void serve_connection(boost::asio::ip::tcp::socket socket,
                      boost::asio::ssl::context* tls,
                      const SessionContext& context,
                      std::optional<KeyedLimit::Slot> connection,
                      bool operations_only = false);

}  // namespace arscout::http
