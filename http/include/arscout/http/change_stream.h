// Follows the server's change feed over the /v1/subscribe WebSocket.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "arscout/http/client.h"

namespace arscout::http {

class ChangeStream {
 public:
  // Connects and subscribes to changes after `since` matching `pattern`.
  // Throws NetworkError when the connection or the upgrade fails (the
  // message carries the HTTP status of a refused upgrade).
  ChangeStream(const ClientOptions& options, std::int64_t since,
               const std::string& pattern = "/**");
  ~ChangeStream();
  ChangeStream(const ChangeStream&) = delete;
  ChangeStream& operator=(const ChangeStream&) = delete;

  // The next change (its JSON, see docs/api.md), or nullopt when none came
  // within the timeout. Throws NetworkError once the connection has ended.
  std::optional<nlohmann::json> next(std::chrono::milliseconds timeout);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace arscout::http
