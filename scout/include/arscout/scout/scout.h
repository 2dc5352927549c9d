// The scout's upload client, the library behind `arscout scout`
// (docs/cli.md): photos sent one by one as POST /v1/captures, each with
// its GPS fix from a CSV or a GPX track (else the server reads the EXIF
// GPS), under an idempotent capture id, retried with back-off, and one
// line printed per photo. The CLI only maps options and exit codes.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <iosfwd>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "arscout/http/client.h"

namespace arscout::scout {

// What a scouting run is asked to do: `arscout scout`'s options.
struct ScoutOptions {
  http::ClientOptions client;
  // Where each photo's request GPS comes from: a CSV row by file name
  // (read_gps_csv), or a GPX track by the EXIF capture time (read_gpx,
  // fix_at); at most one. With neither, none is sent and the server uses
  // the photo's EXIF GPS.
  std::string gps_csv;
  std::string gpx;
  // Seconds the camera clock runs ahead of UTC. Set, the photo's EXIF time
  // shifted by it is sent as "taken"; unset, the EXIF time is taken as UTC
  // for the GPX match and the server keeps EXIF's zone-less time.
  std::optional<double> time_offset_s;
  double gpx_max_gap_s = 60;  // a photo may be this far off the track
  double interval_s = 0;      // the pause between two photos
  std::string site_hint;      // sent as metadata when not empty
  std::string camera;         // a /cameras/{id}, sent when not empty
  std::string scout_name;     // capture id prefix (scout_capture_id)
  int retries = 8;            // of a network error, 408, 429 or 5xx
  double watch_poll_s = 1.0;  // ScoutClient::watch's folder polls
};

// The world outside a run, replaceable by tests. Unset members keep the
// defaults. What a hook throws propagates out of the ScoutClient call.
struct ScoutHooks {
  std::ostream* out = nullptr;  // the lines per photo; default std::cout
  std::ostream* err = nullptr;  // retry notes, unreadable folders; std::cerr
  // Polled before each photo and retry: true ends the run early (the CLI's
  // SIGINT/SIGTERM). Default: never.
  std::function<bool()> stop_requested;
  // Waits `seconds` (the interval, back-off, folder polls); returns false
  // when the wait was cut short by a stop. Default: sleeps in slices of
  // 0.1 s, polling stop_requested.
  std::function<bool(double seconds)> sleep;
  // Called with (the capture id the server stored, the file name) for each
  // photo stored, on the uploading thread (the CLI's --overlay).
  std::function<void(const std::string&, const std::string&)> on_stored;
};

// What a run has done so far.
struct ScoutTotals {
  int succeeded = 0;             // photos the server stored (or replayed)
  int failed = 0;                // photos not stored, for any reason
  std::uint64_t bytes_sent = 0;  // of the photos stored
  // A 401 or 403: the token or its role was refused, so every later photo
  // would be too; the run stops.
  bool refused = false;
};

// Uploads photos. One HTTP connection, kept alive; not thread-safe.
class ScoutClient {
 public:
  // Connects nothing yet. Reads the GPS file; throws std::runtime_error
  // naming it (and the line) when it cannot be read or is malformed, and
  // std::invalid_argument for a malformed server URL.
  explicit ScoutClient(ScoutOptions options, ScoutHooks hooks = {});
  ~ScoutClient();
  ScoutClient(const ScoutClient&) = delete;
  ScoutClient& operator=(const ScoutClient&) = delete;

  // Waits the interval after the previous photo (not before the first);
  // false when a stop cut the wait short.
  bool pace();

  // One photo from start to end: reads it, finds its fix, POSTs it with
  // retries, and prints its line ("NAME  gps SOURCE ...  STATUS ID seq N
  // STATUS  BYTES B  MS ms"). Never throws for the photo's sake: a file
  // that is no photo or cannot be read, a refusal or a network error is
  // counted as failed and printed as "NAME  WHY" (or its line with the
  // answer). No pacing: see pace() and upload_all().
  void upload(const std::filesystem::path& photo);

  // upload() for each photo in order, paced, until a stop or a refusal.
  // Returns how many were handled (photos.size() unless stopped early).
  std::size_t upload_all(const std::vector<std::filesystem::path>& photos);

  // Polls `dir` every watch_poll_s until a stop or a refusal, uploading
  // each new photo once it looks the same on two polls in a row (so a
  // photo still being copied in is not sent half-written). Photos
  // upload_all() handled already are not sent again.
  void watch(const std::string& dir);

  const ScoutTotals& totals() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// "S of T photos uploaded (B B), F failed", and when `left_over` photos
// were not handled, ", token refused before N more" (or ", interrupted
// before N more").
std::string scout_summary(const ScoutTotals& totals, std::size_t left_over);

// ---- the pieces, exposed for the CLI and tests

// "{scout_name}.{file_name}" (just the file name without a scout name),
// characters outside [A-Za-z0-9._-] made '_', at most 128 characters (a
// longer one keeps its start and ends in a hash of the whole). The same
// file gives the same id, so a retry or a re-run is answered as a replay;
// the server files it under the token's name ("{token}.{id}", docs/api.md).
std::string scout_capture_id(std::string_view scout_name,
                             std::string_view file_name);

// A .jpg, .jpeg or .png (any case) whose name does not start with '.'
// ("._IMG_0001.jpg" is macOS metadata, not a photo).
bool is_photo_file(const std::filesystem::path& path);

// The photos (is_photo_file) directly in `dir`, in file-name order. A
// folder that cannot be read has none: says so on `err`, never throws.
std::vector<std::filesystem::path> list_photos(const std::string& dir,
                                               std::ostream& err);

// `files` in file-name order (stable: equal names keep their order).
std::vector<std::filesystem::path> sorted_by_file_name(
    const std::vector<std::string>& files);

// Whether an answer with this status is worth another try: 408, 429, 5xx.
bool is_retryable_status(int status);

// Seconds to wait before retry number `retry` (0 first): 0.5 s doubling to
// 8 s, or the answer's Retry-After when longer (at most 60 s).
double retry_delay_s(int retry, const http::HttpResult* answer);

// "kind: message" from the API's JSON error body, else "HTTP N: " and the
// start of the body.
std::string answer_error_text(const http::HttpResult& answer);

}  // namespace arscout::scout
