#include "raw_http.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <thread>

namespace arscout::testing {
int connect_local(std::uint16_t port) {
  int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(port);
  inet_pton(AF_INET, "127.0.0.1", &addr.sin_addr);
  if (connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    close(fd);
    return -1;
  }
  timeval tv{30, 0};
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
  return fd;
}

namespace {

std::string read_all(int fd) {
  std::string reply;
  char buf[4096];
  ssize_t n;
  while ((n = recv(fd, buf, sizeof buf, 0)) > 0) reply.append(buf, n);
  return reply;
}

}  // namespace

std::string raw_exchange(std::uint16_t port, const std::string& bytes,
                         std::chrono::milliseconds per_byte) {
  const int fd = connect_local(port);
  if (fd < 0) return "connect failed";
  if (per_byte.count() == 0) {
    send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL);
  } else {
    for (char c : bytes) {
      if (send(fd, &c, 1, MSG_NOSIGNAL) != 1) break;
      std::this_thread::sleep_for(per_byte);
    }
  }
  std::string reply = read_all(fd);
  close(fd);
  return reply;
}

BodyAttempt send_large_body(std::uint16_t port, const std::string& header,
                            std::uint64_t body_bytes) {
  BodyAttempt out;
  const int fd = connect_local(port);
  if (fd < 0) {
    out.reply = "connect failed";
    return out;
  }
  send(fd, header.data(), header.size(), MSG_NOSIGNAL);
  const std::string piece(64 * 1024, 'x');
  while (out.body_sent < body_bytes) {
    const size_t n = static_cast<size_t>(
        std::min<std::uint64_t>(piece.size(), body_bytes - out.body_sent));
    const ssize_t sent = send(fd, piece.data(), n, MSG_NOSIGNAL);
    if (sent <= 0) break;
    out.body_sent += static_cast<std::uint64_t>(sent);
  }
  out.reply = read_all(fd);
  close(fd);
  return out;
}

}  // namespace arscout::testing
