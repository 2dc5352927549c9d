#include "metrics.h"

#include <sstream>

namespace arscout::ingest {

void Metrics::record_request(const std::string& route, int status,
                             double seconds) {
  std::lock_guard lock(mu_);
  ++requests_[{route, status}];
  latency_[route].observe(seconds);
}

void Metrics::refused(const std::string& reason) {
  const bool known = reason == "connections" || reason == "streams" ||
                     reason == "slow_body" || reason == "auth_failures" ||
                     reason == "uploads" || reason == "new_places" ||
                     reason == "bodies";
  std::lock_guard lock(mu_);
  ++refused_[known ? reason : "other"];
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
  for (const auto& [route, h] : latency_)
    out << h.render("arscout_http_request_duration_seconds",
                    "route=\"" + route + "\"");
  out << "# HELP arscout_upload_bytes_total Bytes of accepted image uploads.\n"
         "# TYPE arscout_upload_bytes_total counter\n"
      << "arscout_upload_bytes_total " << upload_bytes_.load() << "\n"
      << "# HELP arscout_active_connections Open client connections.\n"
         "# TYPE arscout_active_connections gauge\n"
      << "arscout_active_connections " << active_connections_.load() << "\n"
      << "# HELP arscout_store_errors_total Store failures (unavailable or "
         "internal) while serving requests.\n"
         "# TYPE arscout_store_errors_total counter\n"
      << "arscout_store_errors_total " << store_errors_.load() << "\n"
      << "# HELP arscout_open_streams Long-polls and WebSocket streams "
         "waiting for changes.\n"
         "# TYPE arscout_open_streams gauge\n"
      << "arscout_open_streams " << open_streams_.load() << "\n"
      << "# HELP arscout_refused_total Clients turned away by a cap, by "
         "reason.\n# TYPE arscout_refused_total counter\n";
  for (const auto& [reason, n] : refused_)
    out << "arscout_refused_total{reason=\"" << reason << "\"} " << n << "\n";
  return out.str();
}

}  // namespace arscout::ingest
