// The server's listener: the socket it accepts on, TLS setup, the caps on
// connections and the threads. Each accepted connection is handed to its
// session (beast_session.h), which reads and answers its requests.
#include <utility>  // before Asio, for C++20

#include <netinet/in.h>
#include <netinet/tcp.h>
#include <spdlog/spdlog.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <boost/asio/buffer.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/ssl/context.hpp>
#include <boost/asio/strand.hpp>
#include <boost/asio/thread_pool.hpp>
#include <thread>

#include "arscout/http/keyed_limit.h"
#include "arscout/http/server.h"
#include "beast_session.h"

namespace arscout::http {

namespace asio = boost::asio;
namespace ssl = asio::ssl;
using tcp = asio::ip::tcp;

namespace {

// The connection cap, kept under the process's open-file limit (with room
// for the process's other files, a store's, and the threads' pipes): past
// it accept() would fail for every client, the well-behaved ones too.
std::size_t connection_cap(std::size_t wanted) {
  constexpr rlim_t kReserved = 64;
  rlimit files{};
  if (getrlimit(RLIMIT_NOFILE, &files) != 0 || files.rlim_cur == RLIM_INFINITY)
    return wanted;
  const auto room = static_cast<std::size_t>(files.rlim_cur > 2 * kReserved
                                                 ? files.rlim_cur - kReserved
                                                 : files.rlim_cur / 2);
  return wanted == 0 ? room : std::min(wanted, room);
}

// What a connection past a cap gets: a short 503, written without waiting
// (a fresh socket's send buffer takes it), then the close.
void turn_away(tcp::socket& socket, const std::string& why) {
  const std::string body =
      R"({"error":"unavailable","message":")" + why + R"("})";
  const std::string response =
      "HTTP/1.1 503 Service Unavailable\r\nContent-Type: application/json\r\n"
      "Retry-After: 5\r\nConnection: close\r\nContent-Length: " +
      std::to_string(body.size()) + "\r\n\r\n" + body;
  boost::system::error_code ec;
  socket.non_blocking(true, ec);
  socket.write_some(asio::buffer(response), ec);
  socket.shutdown(tcp::socket::shutdown_both, ec);
  socket.close(ec);
}

}  // namespace

struct Server::Impl {
  Impl(ServerLimits given, Service& service)
      : limits(std::move(given)),
        service(service),
        workers(static_cast<std::size_t>(std::max(1, limits.worker_threads))),
        long_workers(
            static_cast<std::size_t>(std::max(1, limits.long_worker_threads))),
        piece_workers(2),
        operations_workers(2),
        send_budget(limits.max_send_buffer_bytes),
        bodies(0, limits.max_bodies_per_token),
        body_budget(limits.max_body_buffer_bytes),
        streams(limits.max_streams, limits.max_streams_per_token),
        connections(connection_cap(limits.max_connections),
                    limits.max_connections_per_address),
        operations_connections(kOperationsConnections, 0),
        acceptor(ioc),
        tls_context(ssl::context::tls_server) {}

  void load_tls() {
    if (limits.tls_cert.empty() != limits.tls_key.empty())
      throw std::runtime_error("--tls-cert and --tls-key go together");
    if (limits.tls_cert.empty()) return;
    use_tls = true;
    tls_context.set_options(ssl::context::default_workarounds |
                            ssl::context::no_sslv2 | ssl::context::no_sslv3 |
                            ssl::context::no_tlsv1 | ssl::context::no_tlsv1_1);
    boost::system::error_code ec;
    tls_context.use_certificate_chain_file(limits.tls_cert, ec);
    if (ec)
      throw std::runtime_error("cannot load TLS certificate " +
                               limits.tls_cert + ": " + ec.message());
    tls_context.use_private_key_file(limits.tls_key, ssl::context::pem, ec);
    if (ec)
      throw std::runtime_error("cannot load TLS key " + limits.tls_key + ": " +
                               ec.message());
  }

  void listen() {
    boost::system::error_code ec;
    auto address = asio::ip::make_address(limits.host, ec);
    if (ec) throw std::runtime_error("invalid listen address " + limits.host);
    tcp::endpoint endpoint(address, limits.port);
    acceptor.open(endpoint.protocol(), ec);
    if (!ec) acceptor.set_option(asio::socket_base::reuse_address(true), ec);
    if (!ec) acceptor.bind(endpoint, ec);
    if (!ec) acceptor.listen(asio::socket_base::max_listen_connections, ec);
    if (ec)
      throw std::runtime_error("cannot listen on " + limits.host + ":" +
                               std::to_string(limits.port) + ": " +
                               ec.message());
    bound_port = acceptor.local_endpoint().port();
  }

  void accept() {
    acceptor.async_accept(
        asio::make_strand(ioc),
        [this](boost::system::error_code ec, tcp::socket socket) {
          if (ec == asio::error::operation_aborted) return;
          if (!ec) start_session(std::move(socket));
          accept();
        });
  }

  // A client that stops reading keeps at most this much of a response unsent
  // in the kernel (TCP_NOTSENT_LOWAT bounds what a write may queue beyond
  // the bytes in flight, which autotuning still sizes for a far client).
  // Without it each blob download had megabytes copied into its socket at
  // once: in the combined attack of issue 37 (32 clients never reading a
  // 50 MB blob among 160 attackers), /healthz took 57-129 ms as they began
  // or ended (3 runs), and 23-37 ms with it (5 runs; 2 cores).
  static void bound_unsent(tcp::socket& socket) {
    constexpr int kUnsentBytes = 256 << 10;
    setsockopt(socket.native_handle(), IPPROTO_TCP, TCP_NOTSENT_LOWAT,
               &kUnsentBytes, sizeof(kUnsentBytes));  // best effort
  }

  void start_session(tcp::socket socket) {
    bound_unsent(socket);
    boost::system::error_code ec;
    const auto peer = socket.remote_endpoint(ec);
    const std::string address = ec ? "" : peer.address().to_string();
    auto slot = connections.acquire(address);
    // Past the address's cap (not the total), a connection may still ask
    // for /healthz: from the small pool for that, briefly.
    const bool over_address_cap =
        !slot && (connections.total_cap() == 0 ||
                  connections.in_use() < connections.total_cap());
    if (over_address_cap) slot = operations_connections.acquire(address);
    if (!slot) {
      service.metrics().refused("connections");
      return turn_away(socket, "too many connections (at most " +
                                   std::to_string(connections.per_key_cap()) +
                                   " per address, " +
                                   std::to_string(connections.total_cap()) +
                                   " in all)");
    }
    serve_connection(std::move(socket), use_tls ? &tls_context : nullptr,
                     SessionContext{service, limits, workers, long_workers,
                                    operations_workers, piece_workers,
                                    send_budget, bodies, body_budget, streams},
                     std::move(slot), over_address_cap);
  }

  ServerLimits limits;
  Service& service;
  // Before the io_context, so they are destroyed after it: sessions still
  // queued there when the server stops release their slots as they go (and
  // cancel their wake-ups with the Service, which outlives the server).
  asio::thread_pool workers;
  asio::thread_pool long_workers;
  asio::thread_pool piece_workers;
  asio::thread_pool operations_workers;
  ByteBudget send_budget;
  KeyedLimit bodies;
  ByteBudget body_budget;
  KeyedLimit streams;
  KeyedLimit connections;
  // Connections past their address's cap that may ask /healthz only.
  static constexpr std::size_t kOperationsConnections = 64;
  KeyedLimit operations_connections;
  asio::io_context ioc;
  tcp::acceptor acceptor;
  ssl::context tls_context;
  bool use_tls = false;
  std::uint16_t bound_port = 0;
  std::vector<std::thread> threads;
};

Server::Server(ServerLimits limits, Service& service)
    : impl_(std::make_unique<Impl>(std::move(limits), service)) {}

Server::~Server() { stop(); }

void Server::start() {
  impl_->load_tls();
  impl_->listen();
  impl_->accept();
  for (int i = 0; i < std::max(1, impl_->limits.io_threads); ++i)
    impl_->threads.emplace_back([this] { impl_->ioc.run(); });
  spdlog::info(
      "event=listening host={} port={} tls={} max_connections={} "
      "max_connections_per_address={} max_streams={}",
      impl_->limits.host, impl_->bound_port, impl_->use_tls,
      impl_->connections.total_cap(), impl_->connections.per_key_cap(),
      impl_->streams.total_cap());
}

void Server::stop() {
  if (impl_->threads.empty()) return;
  asio::post(impl_->ioc, [this] {
    boost::system::error_code ignored;
    impl_->acceptor.close(ignored);
  });
  impl_->ioc.stop();
  for (auto& t : impl_->threads) t.join();
  impl_->threads.clear();
  impl_->workers.join();
  impl_->long_workers.join();
  impl_->piece_workers.join();
  impl_->operations_workers.join();
}

std::uint16_t Server::port() const { return impl_->bound_port; }
bool Server::tls() const { return impl_->use_tls; }

}  // namespace arscout::http
