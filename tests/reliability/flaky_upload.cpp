#include "flaky_upload.h"

#include "raw_http.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <thread>

namespace arscout::testing {

Interruption interruption_for(int scout, int capture) {
  switch ((scout * 7 + capture) % 6) {
    case 0:
      return Interruption::kCutMidBody;
    case 1:
      return Interruption::kResetMidBody;
    case 2:
      return Interruption::kLostAnswer;
    default:
      return Interruption::kNone;
  }
}

void interrupted_upload(std::uint16_t port, const std::string& token,
                        const std::string& metadata, const std::string& jpeg,
                        Interruption how, double fraction_sent) {
  if (how == Interruption::kNone) return;
  const int fd = connect_local(port);
  if (fd < 0) return;  // as good as cut: the retry follows
  std::string head =
      "POST /v1/captures HTTP/1.1\r\nHost: 127.0.0.1\r\n"
      "Authorization: Bearer " +
      token +
      "\r\nContent-Type: image/jpeg\r\nX-Capture-Metadata: " + metadata +
      "\r\nContent-Length: " + std::to_string(jpeg.size()) + "\r\n\r\n";
  std::size_t body =
      how == Interruption::kLostAnswer
          ? jpeg.size()
          : static_cast<std::size_t>(std::clamp(fraction_sent, 0.0, 0.99) *
                                     static_cast<double>(jpeg.size()));
  std::string bytes = head + jpeg.substr(0, body);
  for (std::size_t sent = 0; sent < bytes.size();) {
    ssize_t n =
        send(fd, bytes.data() + sent, bytes.size() - sent, MSG_NOSIGNAL);
    if (n <= 0) break;
    sent += static_cast<std::size_t>(n);
  }
  if (how == Interruption::kResetMidBody) {
    linger hard{1, 0};  // close() then sends RST instead of FIN
    setsockopt(fd, SOL_SOCKET, SO_LINGER, &hard, sizeof hard);
  }
  close(fd);
}

UploadOutcome upload_until_stored(http::Client& client,
                                  const std::string& metadata,
                                  const std::string& jpeg, int max_tries) {
  UploadOutcome out;
  for (int attempt = 0; attempt < max_tries; ++attempt) {
    try {
      http::HttpResult r = client.request(
          "POST", "/v1/captures", jpeg,
          {{"Content-Type", "image/jpeg"}, {"X-Capture-Metadata", metadata}});
      ++out.attempts;
      out.status = r.status;
      out.body = r.body;
      if (r.status < 500) {
        auto replay = r.headers.find("idempotent-replay");
        out.replay = replay != r.headers.end() && replay->second == "true";
        return out;
      }
    } catch (const http::NetworkError& e) {
      out.status = 0;
      out.body = e.what();
    }
    ++out.retries;
    out.retry_reasons.push_back(std::to_string(out.status) + " " + out.body);
    std::this_thread::sleep_for(
        std::chrono::milliseconds(std::min(100 << std::min(attempt, 4), 1000)));
  }
  return out;
}

std::uint16_t port_of(const std::string& url) {
  return static_cast<std::uint16_t>(std::stoi(url.substr(url.rfind(':') + 1)));
}

}  // namespace arscout::testing
