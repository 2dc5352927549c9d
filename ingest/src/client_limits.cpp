#include "client_limits.h"

#include "arscout/util/geodesy.h"

namespace arscout::ingest {
namespace {

// Places remembered per token: a scout opens a few new places an hour.
constexpr std::size_t kRecentPlaces = 64;

}  // namespace

NewPlaces::NewPlaces(double distance_m, double per_hour, double burst)
    : distance_m_(distance_m), rate_(per_hour, burst) {}

bool NewPlaces::near_recent(const std::string& token, double lat, double lon) {
  std::lock_guard lock(mutex_);
  for (const Place& p : recent_[token])
    if (util::great_circle_m(lat, lon, p.lat, p.lon) <= distance_m_)
      return true;
  return false;
}

bool NewPlaces::near_site(db::Store& store, double lat, double lon) const {
  db::Query q;
  q.pattern = "/sites/*";
  q.near = db::GeoRadius{lat, lon, distance_m_};
  q.limit = 1;
  return !store.query(q).empty();
}

int NewPlaces::admit(db::Store& store, const std::string& token, double lat,
                     double lon) {
  if (!rate_.limited() || near_recent(token, lat, lon) ||
      near_site(store, lat, lon))
    return 0;
  const int wait = rate_.take(token);
  if (wait > 0) return wait;
  std::lock_guard lock(mutex_);
  auto& places = recent_[token];
  places.push_back(Place{lat, lon});
  if (places.size() > kRecentPlaces) places.pop_front();
  return 0;
}

ClientLimits::ClientLimits()
    : uploads(0, 1), new_places(0, 0, 1), auth_failures(0, 1) {}

ClientLimits::ClientLimits(const ServerOptions& o)
    : uploads(o.uploads_per_hour, o.upload_burst),
      new_places(o.new_place_m, o.new_places_per_hour, o.new_place_burst),
      auth_failures(o.auth_failures_per_hour, o.auth_failure_burst) {}

HttpResponse too_many_requests(const std::string& kind,
                               const std::string& message, int seconds) {
  HttpResponse r =
      HttpResponse::error(429, kind, message, Json{{"retry_after_s", seconds}});
  r.headers.emplace_back("Retry-After", std::to_string(seconds));
  return r;
}

HttpResponse uploads_refused(int seconds) {
  return too_many_requests(
      "too_many_uploads",
      "this token has sent more captures than its rate allows; send again "
      "after Retry-After seconds",
      seconds);
}

HttpResponse new_places_refused(int seconds) {
  return too_many_requests(
      "too_many_new_places",
      "this token has sent captures from more new places (each may found a "
      "site) than its rate allows; send again after Retry-After seconds",
      seconds);
}

}  // namespace arscout::ingest
