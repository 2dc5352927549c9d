// The scout client's private pieces (scout.h), shared by its files here:
// photos.cpp (names, ids, folders), gps_source.cpp (where a fix comes
// from), report.cpp (the lines it prints), scout_client.cpp (one upload),
// watch.cpp (--watch).
#pragma once

#include <filesystem>
#include <map>
#include <optional>
#include <ostream>
#include <set>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "arscout/http/client.h"
#include "arscout/metadata/gps.h"
#include "arscout/scout/scout.h"

namespace arscout::scout {

// What the client speaks (http/) and what it reads from photos and GPS
// files (metadata/), by their short names in the scout's own files.
using http::Client;
using http::HttpResult;
using http::NetworkError;
using metadata::ExifInfo;
using metadata::fix_at;
using metadata::format_time_utc;
using metadata::GpsFix;
using metadata::Json;
using metadata::parse_time_utc;
using metadata::read_exif;
using metadata::read_gps_csv;
using metadata::read_gpx;
using metadata::to_json;
using metadata::TrackPoint;

}  // namespace arscout::scout

namespace arscout::scout::detail {

using Headers = std::vector<std::pair<std::string, std::string>>;

// [A-Za-z0-9._-] kept, anything else '_': a safe single path segment.
std::string sanitise(std::string_view s);

// "image/png" or "image/jpeg" by magic number; by the extension only when
// the bytes are neither (the server then says what is wrong with them).
std::string content_type(const std::string& bytes,
                         const std::filesystem::path& path);

// Where a photo's request GPS comes from: a CSV row by file name, a GPX
// track by the EXIF capture time, or nowhere (the server then reads the
// EXIF GPS).
class GpsSource {
 public:
  // Reads the file the options name; throws std::runtime_error.
  explicit GpsSource(const ScoutOptions& options);

  // nullopt, with *why when a GPS file gives no fix for this photo.
  std::optional<GpsFix> fix_for(const std::string& file_name,
                                const ExifInfo& exif, std::string* why) const;

  // EXIF DateTimeOriginal as UTC seconds: the camera clock is taken as UTC
  // unless time_offset_s says how far ahead of UTC it runs.
  std::optional<std::int64_t> taken_utc(const ExifInfo& exif) const;

 private:
  std::optional<GpsFix> from_csv(const std::string& file_name,
                                 std::string* why) const;
  std::optional<GpsFix> from_gpx(const ExifInfo& exif, std::string* why) const;

  const ScoutOptions& options_;
  std::map<std::string, GpsFix> csv_;
  std::vector<TrackPoint> track_;
};

// What one upload ended with.
struct UploadOutcome {
  std::optional<HttpResult> answer;
  std::string error;  // the last network error when there is no answer
  int attempts = 0;
  double round_trip_ms = 0;  // of the last attempt
};

// "csv ±2.1 m 8 sat" from a fix in its JSON form.
std::string describe_gps(const Json& gps);

// The GPS the photo is sent with, before the answer says which fix the
// server kept: ours, else EXIF's, else "none".
std::string planned_gps(const std::optional<GpsFix>& fix, const ExifInfo& exif);

// The id the server stored the capture under (its document's path), else
// the one sent.
std::string stored_id(const HttpResult& answer, const std::string& sent);

// The site whose model the answer's capture was placed in, when it names
// one that is a safe path segment.
std::optional<std::string> placed_site(const HttpResult& answer);

// The middle of a stored photo's line: "exif ±25.0 m  201 alice.01.jpg seq
// 17 stored", then "  " and `model` when there is one. `gps_text` is
// planned_gps(), `why` why the GPS file had no fix ("" when it had).
std::string accepted_text(const HttpResult& answer, const std::string& id,
                          const std::string& gps_text, const std::string& why,
                          const std::optional<std::string>& model);

// The middle of a failed photo's line: the GPS, the answer or the error.
std::string failed_text(const UploadOutcome& outcome,
                        const std::string& gps_text, const std::string& why);

// "  NAME: WHAT; retry N/M in S s" on its own line.
std::string retry_note(const std::string& name, const UploadOutcome& outcome,
                       int retry, int retries, double delay_s);

}  // namespace arscout::scout::detail

namespace arscout::scout {

// The state of one ScoutClient.
struct ScoutClient::Impl {
  Impl(ScoutOptions options, ScoutHooks hooks);

  bool stopped() const;
  // hooks.sleep, or sleeping in slices until a stop; false when stopped.
  bool wait(double seconds);
  void upload(const std::filesystem::path& path);

  ScoutOptions options;
  ScoutHooks hooks;
  std::ostream& out;
  std::ostream& err;
  Client client;
  detail::GpsSource gps;
  ScoutTotals totals;
  int uploads_started = 0;
  std::set<std::string> done;  // the file names handled, for watch()

 private:
  void send(const std::string& name, const std::string& bytes,
            const std::filesystem::path& path);
  Json metadata(const std::string& id, const std::string& name,
                const std::optional<GpsFix>& fix, const ExifInfo& exif) const;
  detail::UploadOutcome post_with_retries(const std::string& name,
                                          const std::string& bytes,
                                          const detail::Headers& headers);
  void attempt(const std::string& bytes, const detail::Headers& headers,
               detail::UploadOutcome* out);
  void report(const std::string& name, const std::string& id, std::size_t size,
              const std::string& gps_text, const std::string& why,
              const detail::UploadOutcome& outcome);
  std::optional<std::string> model_version(const HttpResult& answer);
  void fail(const std::string& name, const std::string& why);
};

}  // namespace arscout::scout
