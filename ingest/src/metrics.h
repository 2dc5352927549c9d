// Server metrics in the Prometheus text exposition format.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <utility>

namespace arscout::ingest {

class Metrics {
 public:
  // One finished request: its route template (e.g. "/v1/docs/*"), status and
  // duration.
  void record_request(const std::string& route, int status, double seconds);
  void add_upload_bytes(std::int64_t bytes) { upload_bytes_ += bytes; }
  void store_error() { ++store_errors_; }
  void connection_opened() { ++active_connections_; }
  void connection_closed() { --active_connections_; }

  std::string render() const;

 private:
  static constexpr std::array<double, 12> kBuckets = {
      0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1, 2.5, 10};
  struct Histogram {
    std::array<std::uint64_t, kBuckets.size()> counts{};
    std::uint64_t count = 0;
    double sum = 0;
  };

  mutable std::mutex mu_;
  std::map<std::pair<std::string, int>, std::uint64_t> requests_;
  std::map<std::string, Histogram> latency_;
  std::atomic<std::int64_t> upload_bytes_{0};
  std::atomic<std::int64_t> store_errors_{0};
  std::atomic<std::int64_t> active_connections_{0};
};

}  // namespace arscout::ingest
