// What one client may do per hour (ServerOptions, docs/api.md "Limits"):
// uploads and new places per token, failed authentications per address.
// Past a limit a request is answered 429 with Retry-After.
#pragma once

#include <deque>
#include <map>
#include <mutex>
#include <string>

#include "arscout/db/store.h"
#include "arscout/http/http_types.h"
#include "arscout/http/keyed_rate.h"
#include "arscout/ingest/server.h"

namespace arscout::ingest {

// Captures that may found a site: their fix lies farther than `distance_m`
// from every stored site and from every place the same token opened lately
// (the engine founds sites a moment after the upload, so the token's own
// recent places stand in for those not stored yet). Each such capture takes
// one event from the token's bucket; a walk that stays in one place takes
// one in all. Thread-safe.
class NewPlaces {
 public:
  NewPlaces(double distance_m, double per_hour, double burst);

  // 0 when a capture of `token` at (lat, lon) may be stored, else the
  // seconds to wait. Reads the sites near the fix from `store`.
  int admit(db::Store& store, const std::string& token, double lat, double lon);

 private:
  struct Place {
    double lat, lon;
  };
  bool near_recent(const std::string& token, double lat, double lon);
  bool near_site(db::Store& store, double lat, double lon) const;

  const double distance_m_;
  http::KeyedRate rate_;
  std::mutex mutex_;
  std::map<std::string, std::deque<Place>> recent_;  // per token, newest last
};

struct ClientLimits {
  // No limits at all (an Api without ServerOptions, as tests build one).
  ClientLimits();
  explicit ClientLimits(const ServerOptions& options);

  http::KeyedRate uploads;        // per token name
  NewPlaces new_places;           // per token name
  http::KeyedRate auth_failures;  // per client address
};

// 429 `kind` with `message` and Retry-After: seconds.
HttpResponse too_many_requests(const std::string& kind,
                               const std::string& message, int seconds);
// The 429s of the two upload limits.
HttpResponse uploads_refused(int seconds);
HttpResponse new_places_refused(int seconds);

}  // namespace arscout::ingest
