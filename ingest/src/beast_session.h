// One accepted connection's HTTP/1.1 session (beast_session.cpp), served
// until it closes. Apart from the listener (beast_server.cpp): the session
// instantiates Beast's templates, the listener only Asio's acceptor.
#pragma once

#include <utility>  // before Asio, for C++20

#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/ssl/context.hpp>
#include <boost/asio/thread_pool.hpp>
#include <optional>

#include "api.h"
#include "arscout/ingest/server.h"
#include "change_watch.h"
#include "keyed_limit.h"

namespace arscout::ingest {

// What every session of one server shares.
struct SessionContext {
  Api& api;
  const ServerOptions& options;
  boost::asio::thread_pool& workers;
  ChangeWatch& watch;   // long-polls and streams wait here, threadless
  KeyedLimit& streams;  // open long-polls and streams, per token
};

// Serves `socket` (over TLS with `tls`, plain HTTP when it is null) until
// the connection closes, holding its `connection` slot until then.
void serve_connection(boost::asio::ip::tcp::socket socket,
                      boost::asio::ssl::context* tls,
                      const SessionContext& context,
                      std::optional<KeyedLimit::Slot> connection);

}  // namespace arscout::ingest
