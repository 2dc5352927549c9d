// Uploads as a phone on a poor link makes them: attempts cut off mid-body,
// reset, or whose answer never arrives, then retried until the server
// acknowledges the capture.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "arscout/http/client.h"

namespace arscout::testing {

enum class Interruption {
  kNone,
  kCutMidBody,    // closes the connection part-way through the body
  kResetMidBody,  // the same, with a TCP reset
  kLostAnswer,    // sends everything, hangs up before the answer
};

struct UploadOutcome {
  int attempts = 0;     // requests that got an answer
  int retries = 0;      // answers of 5xx and network errors retried
  bool replay = false;  // the server had stored it already
  int status = 0;       // the last answer
  std::string body;     // ... and its body
  std::vector<std::string> retry_reasons;  // status and body of each retry
};

// The interruption a scout's i-th capture suffers first (half do).
Interruption interruption_for(int scout, int capture);

// One interrupted attempt on a fresh connection to 127.0.0.1:port.
void interrupted_upload(std::uint16_t port, const std::string& token,
                        const std::string& metadata, const std::string& jpeg,
                        Interruption how, double fraction_sent);

// POST /v1/captures until it is answered 201 (or a 4xx, which is final),
// retrying network errors and 5xx with a short back-off, at most max_tries.
UploadOutcome upload_until_stored(http::Client& client,
                                  const std::string& metadata,
                                  const std::string& jpeg, int max_tries = 40);

// "http://127.0.0.1:PORT" -> PORT.
std::uint16_t port_of(const std::string& url);

}  // namespace arscout::testing
