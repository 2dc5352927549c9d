// Server metrics in the Prometheus text exposition format: the API's
// requests and uploads, and what the transport counts (http::ServerMetrics:
// connections, streams, clients turned away).
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <utility>

#include "arscout/http/server.h"
#include "arscout/util/histogram.h"

namespace arscout::ingest {

class Metrics : public http::ServerMetrics {
 public:
  // One finished request: its route template (e.g. "/v1/docs/*"), status and
  // duration.
  void record_request(const std::string& route, int status, double seconds);
  void add_upload_bytes(std::int64_t bytes) { upload_bytes_ += bytes; }
  void store_error() { ++store_errors_; }
  void connection_opened() override { ++active_connections_; }
  void connection_closed() override { --active_connections_; }
  // Parked long-polls and WebSocket streams.
  void stream_opened() override { ++open_streams_; }
  void stream_closed() override { --open_streams_; }
  // A client turned away by a cap: the server's ("connections", "streams",
  // "slow_body", "bodies") or the API's ("auth_failures", "uploads",
  // "new_places"); any other reason counts as "other".
  void refused(const std::string& reason) override;
  // Answered by the server from the header: the route "rejected".
  void rejected(int status) override { record_request("rejected", status, 0); }

  std::string render() const;

 private:
  mutable std::mutex mu_;
  std::map<std::pair<std::string, int>, std::uint64_t> requests_;
  std::map<std::string, util::Histogram> latency_;
  std::atomic<std::int64_t> upload_bytes_{0};
  std::atomic<std::int64_t> store_errors_{0};
  std::atomic<std::int64_t> active_connections_{0};
  std::atomic<std::int64_t> open_streams_{0};
  std::map<std::string, std::uint64_t> refused_;  // under mu_
};

}  // namespace arscout::ingest
