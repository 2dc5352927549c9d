#include "metrics.h"

#include <sstream>

namespace arscout::ingest {

void Metrics::record_request(const std::string& route, int status,
                             double seconds) {
  std::lock_guard lock(mu_);
  ++requests_[{route, status}];
  Histogram& h = latency_[route];
  for (std::size_t i = 0; i < kBuckets.size(); ++i)
    if (seconds <= kBuckets[i]) ++h.counts[i];
  ++h.count;
  h.sum += seconds;
}

std::string Metrics::render() const {
  std::ostringstream out;
  std::lock_guard lock(mu_);
  out << "# HELP arscout_http_requests_total HTTP requests by route and "
         "status.\n"
         "# TYPE arscout_http_requests_total counter\n";
  for (const auto& [key, n] : requests_)
    out << "arscout_http_requests_total{route=\"" << key.first << "\",status=\""
        << key.second << "\"} " << n << "\n";
  out << "# HELP arscout_http_request_duration_seconds Request latency by "
         "route.\n# TYPE arscout_http_request_duration_seconds histogram\n";
  for (const auto& [route, h] : latency_) {
    for (std::size_t i = 0; i < kBuckets.size(); ++i)
      out << "arscout_http_request_duration_seconds_bucket{route=\"" << route
          << "\",le=\"" << kBuckets[i] << "\"} " << h.counts[i] << "\n";
    out << "arscout_http_request_duration_seconds_bucket{route=\"" << route
        << "\",le=\"+Inf\"} " << h.count << "\n"
        << "arscout_http_request_duration_seconds_sum{route=\"" << route
        << "\"} " << h.sum << "\n"
        << "arscout_http_request_duration_seconds_count{route=\"" << route
        << "\"} " << h.count << "\n";
  }
  out << "# HELP arscout_upload_bytes_total Bytes of accepted image uploads.\n"
         "# TYPE arscout_upload_bytes_total counter\n"
      << "arscout_upload_bytes_total " << upload_bytes_.load() << "\n"
      << "# HELP arscout_active_connections Open client connections.\n"
         "# TYPE arscout_active_connections gauge\n"
      << "arscout_active_connections " << active_connections_.load() << "\n"
      << "# HELP arscout_store_errors_total Store failures (unavailable or "
         "internal) while serving requests.\n"
         "# TYPE arscout_store_errors_total counter\n"
      << "arscout_store_errors_total " << store_errors_.load() << "\n";
  return out.str();
}

}  // namespace arscout::ingest
