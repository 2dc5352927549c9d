// Raw bytes to a server on 127.0.0.1, for tests of what an HTTP client
// library would never send (malformed framing, slow or endless bodies).
#pragma once

#include <chrono>
#include <cstdint>
#include <string>

namespace arscout::testing {

// A connected TCP socket to 127.0.0.1:port with 30 s send and receive
// timeouts, or -1. The caller closes it.
int connect_local(std::uint16_t port);

// Sends `bytes` on a fresh connection, optionally one byte per `per_byte`,
// and returns what the server answered before closing ("" when it closed
// without a word, "connect failed" when there was no server). Waits at
// most 30 s for the answer.
std::string raw_exchange(
    std::uint16_t port, const std::string& bytes,
    std::chrono::milliseconds per_byte = std::chrono::milliseconds(0));

struct BodyAttempt {
  std::string reply;            // what the server answered
  std::uint64_t body_sent = 0;  // body bytes the connection took
};

// Sends `header` (ending in an empty line), then up to `body_bytes` of body
// in 64 KiB pieces while the server keeps taking them, then reads the
// answer. A server that refuses the request from its header answers and
// closes, and the sending stops short.
BodyAttempt send_large_body(std::uint16_t port, const std::string& header,
                            std::uint64_t body_bytes);

}  // namespace arscout::testing
