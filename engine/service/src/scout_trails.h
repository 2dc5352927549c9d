// Where each scout's photos went lately: a photo that comes with neither a
// GPS fix nor a site hint (location denied on the phone, a camera without
// GPS) goes to the site of its scout's photos taken within a window of it.
// One that has none yet waits "for a position" and follows the first of
// its scout's photos placed within that window.
//
// Times are the photos' own (`taken`, else when the server received them),
// Unix seconds. Used by the placing thread only: not thread-safe.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace arscout::engine::service {

class ScoutTrails {
 public:
  explicit ScoutTrails(std::int64_t window_s) : window_s_(window_s) {}

  // `scout`'s photo taken at `taken_s` was placed in `site`.
  void placed(const std::string& scout, std::int64_t taken_s,
              const std::string& site);

  // The site of `scout`'s placed photo nearest in time to `taken_s`, when
  // one is within the window.
  std::optional<std::string> site_near(const std::string& scout,
                                       std::int64_t taken_s) const;

  // Capture `id` of `scout`, taken at `taken_s`, waits for a position
  // (again: kept once).
  void wait(const std::string& scout, std::int64_t taken_s,
            const std::string& id);

  // The captures of `scout` waiting for a position that were taken within
  // the window of `taken_s`, no longer waiting.
  std::vector<std::string> release(const std::string& scout,
                                   std::int64_t taken_s);

  std::int64_t window_s() const { return window_s_; }

 private:
  std::int64_t window_s_;
  // Per scout: placed photos' times and sites (the latest few hundred),
  // and the captures waiting, by id.
  std::map<std::string, std::multimap<std::int64_t, std::string>> placed_;
  std::map<std::string, std::map<std::string, std::int64_t>> waiting_;
};

}  // namespace arscout::engine::service
