// ingest::Server: the API (api.h) served by http::Server. The API is the
// server's Service here: its answers, its refusals before a body, its long
// routes, the change log's feed for WebSocket subscribers (change_feed.h)
// and the change watch's wake-ups for parked long-polls and feeds.
#include "arscout/ingest/server.h"

#include <chrono>
#include <exception>
#include <memory>

#include "api.h"
#include "change_feed.h"
#include "change_watch.h"
#include "metrics.h"

namespace arscout::ingest {
namespace {

class ApiService : public http::Service {
 public:
  ApiService(Api& api, ChangeWatch& watch, Metrics& metrics)
      : api_(api), watch_(watch), metrics_(metrics) {}

  HttpResponse handle(const HttpRequest& request) override {
    return api_.handle(request);
  }
  std::optional<HttpResponse> refuse_before_body(
      const HttpRequest& head) override {
    return api_.refuse_before_body(head);
  }
  bool runs_long(const HttpRequest& request) const override {
    return api_.runs_long(request);
  }

  // Only /v1/subscribe is a WebSocket; a store that cannot answer
  // (PostgreSQL restarting) is its 503 like any other request's.
  std::variant<std::unique_ptr<http::EventFeed>, HttpResponse> subscribe(
      const HttpRequest& request) override {
    if (request.path != "/v1/subscribe")
      return HttpResponse::error(404, "not_found",
                                 "WebSocket only at /v1/subscribe");
    try {
      auto checked = api_.check_subscribe(request);
      if (auto* refusal = std::get_if<HttpResponse>(&checked))
        return std::move(*refusal);
      return std::make_unique<ChangeFeed>(
          api_.store(), std::move(std::get<Api::Subscribe>(checked)));
    } catch (const db::StoreError& e) {
      metrics_.store_error();
      return error_response(e);
    } catch (const std::exception& e) {
      return HttpResponse::error(500, "internal", e.what());
    }
  }

  std::uint64_t notify_after(std::int64_t after,
                             std::function<void()> wake) override {
    return watch_.notify_after(after, std::move(wake));
  }
  void cancel(std::uint64_t id) override { watch_.cancel(id); }
  http::ServerMetrics& metrics() override { return metrics_; }

 private:
  Api& api_;
  ChangeWatch& watch_;
  Metrics& metrics_;
};

}  // namespace

// Members in the order they must be built: the http::Server last, so that
// it is destroyed first and its sessions, closing then, still find the
// change watch to cancel their wake-ups with.
struct Server::Impl {
  Impl(db::Store& store, ServerOptions options)
      : api(store, metrics, options),
        watch(store, std::chrono::milliseconds(100)),
        service(api, watch, metrics),
        http(std::move(options), service) {}

  Metrics metrics;
  Api api;
  ChangeWatch watch;
  ApiService service;
  http::Server http;
  bool started = false;
};

Server::Server(db::Store& store, ServerOptions options)
    : impl_(std::make_unique<Impl>(store, std::move(options))) {}

Server::~Server() { stop(); }

void Server::start() {
  // The probe runs before the first request can ask /healthz.
  impl_->api.store_health().start(std::chrono::milliseconds(250));
  try {
    impl_->http.start();
  } catch (...) {
    impl_->api.store_health().stop();
    throw;
  }
  impl_->started = true;
}

void Server::stop() {
  if (!impl_->started) return;
  impl_->started = false;
  impl_->http.stop();
  impl_->watch.stop();  // no wake-up is posted to the server after this
  impl_->api.store_health().stop();
}

std::uint16_t Server::port() const { return impl_->http.port(); }
bool Server::tls() const { return impl_->http.tls(); }

}  // namespace arscout::ingest
