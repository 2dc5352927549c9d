// One photo from start to end: read it, find its fix, POST it with
// retries, print its line; and the ScoutClient around it.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "arscout/util/file.h"
#include "scout_internal.h"

namespace arscout::scout {

namespace fs = std::filesystem;
using detail::Headers;
using detail::UploadOutcome;

ScoutClient::Impl::Impl(ScoutOptions options_in, ScoutHooks hooks_in)
    : options(std::move(options_in)),
      hooks(std::move(hooks_in)),
      out(hooks.out ? *hooks.out : std::cout),
      err(hooks.err ? *hooks.err : std::cerr),
      client(options.client),
      gps(options) {}

bool ScoutClient::Impl::stopped() const {
  return hooks.stop_requested && hooks.stop_requested();
}

bool ScoutClient::Impl::wait(double seconds) {
  if (hooks.sleep) return hooks.sleep(seconds);
  // In slices, so that a stop (Ctrl-C) is seen within 0.1 s.
  auto until = std::chrono::steady_clock::now() +
               std::chrono::milliseconds(std::llround(seconds * 1000));
  while (!stopped()) {
    auto left = until - std::chrono::steady_clock::now();
    if (left <= std::chrono::steady_clock::duration::zero()) return true;
    std::this_thread::sleep_for(std::min<std::chrono::steady_clock::duration>(
        left, std::chrono::milliseconds(100)));
  }
  return false;
}

void ScoutClient::Impl::upload(const fs::path& path) {
  ++uploads_started;
  std::string name = path.filename().string();
  if (!is_photo_file(path)) return fail(name, "not a .jpg/.jpeg/.png file");
  std::string bytes;
  try {
    bytes = util::read_file(path.string());
  } catch (const std::runtime_error&) {
    // The photo's line keeps its documented form; the reason is the OS's.
    return fail(name, "cannot read " + path.string());
  }
  send(name, bytes, path);
}

void ScoutClient::Impl::send(const std::string& name, const std::string& bytes,
                             const fs::path& path) {
  auto exif = read_exif(bytes);
  std::string why;
  auto fix = gps.fix_for(name, exif, &why);
  std::string id = scout_capture_id(options.scout_name, name);
  Json meta = metadata(id, name, fix, exif);
  Headers headers{{"Content-Type", detail::content_type(bytes, path)},
                  {"X-Capture-Metadata", meta.dump(-1, ' ', true)}};
  auto outcome = post_with_retries(name, bytes, headers);
  report(name, id, bytes.size(), detail::planned_gps(fix, exif), why, outcome);
  if (outcome.answer &&
      (outcome.answer->status == 401 || outcome.answer->status == 403))
    totals.refused = true;
}

Json ScoutClient::Impl::metadata(const std::string& id, const std::string& name,
                                 const std::optional<GpsFix>& fix,
                                 const ExifInfo& exif) const {
  Json meta{{"capture_id", id}, {"filename", name}};
  if (fix) {
    meta["gps"] = to_json(*fix);
    meta["gps"].erase("source");  // the server records "request"
  }
  if (!options.camera.empty()) meta["camera"] = options.camera;
  if (!options.site_hint.empty()) meta["site_hint"] = options.site_hint;
  // Without an offset the server keeps EXIF's zone-less local time.
  if (auto t = gps.taken_utc(exif); t && options.time_offset_s)
    meta["taken"] = format_time_utc(*t);
  return meta;
}

UploadOutcome ScoutClient::Impl::post_with_retries(const std::string& name,
                                                   const std::string& bytes,
                                                   const Headers& headers) {
  UploadOutcome outcome;
  for (int retry = 0;; ++retry) {
    attempt(bytes, headers, &outcome);
    if (outcome.answer && !is_retryable_status(outcome.answer->status))
      return outcome;
    if (retry >= options.retries || stopped()) return outcome;
    double delay =
        retry_delay_s(retry, outcome.answer ? &*outcome.answer : nullptr);
    err << detail::retry_note(name, outcome, retry, options.retries, delay);
    if (!wait(delay)) return outcome;
  }
}

void ScoutClient::Impl::attempt(const std::string& bytes,
                                const Headers& headers,
                                UploadOutcome* outcome) {
  ++outcome->attempts;
  auto start = std::chrono::steady_clock::now();
  try {
    outcome->answer = client.request("POST", "/v1/captures", bytes, headers);
  } catch (const NetworkError& e) {
    outcome->answer.reset();
    outcome->error = e.what();
  }
  outcome->round_trip_ms = std::chrono::duration<double, std::milli>(
                               std::chrono::steady_clock::now() - start)
                               .count();
}

void ScoutClient::Impl::report(const std::string& name, const std::string& id,
                               std::size_t size, const std::string& gps_text,
                               const std::string& why,
                               const UploadOutcome& outcome) {
  std::ostringstream line;
  line << name << "  gps ";
  if (outcome.answer && outcome.answer->status / 100 == 2) {
    const std::string stored = detail::stored_id(*outcome.answer, id);
    line << detail::accepted_text(*outcome.answer, stored, gps_text, why,
                                  model_version(*outcome.answer));
    ++totals.succeeded;
    if (hooks.on_stored) hooks.on_stored(stored, name);
    totals.bytes_sent += size;
  } else {
    line << detail::failed_text(outcome, gps_text, why);
    ++totals.failed;
  }
  line << "  " << size << " B  " << std::llround(outcome.round_trip_ms)
       << " ms";
  if (outcome.attempts > 1) line << "  (" << outcome.attempts << " attempts)";
  out << line.str() << std::endl;
}

// "site S model vN" when the engine has placed the capture in a site that
// has a model; nothing otherwise (a failed lookup does not fail the photo).
std::optional<std::string> ScoutClient::Impl::model_version(
    const HttpResult& answer) {
  auto site = detail::placed_site(answer);
  if (!site) return std::nullopt;
  try {
    auto model = client.get("/v1/docs/sites/" + *site + "/model");
    if (model.status != 200) return std::nullopt;
    return "site " + *site + " model v" +
           model.json().value("version", Json()).dump();
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

void ScoutClient::Impl::fail(const std::string& name, const std::string& why) {
  out << name << "  " << why << std::endl;
  ++totals.failed;
}

// ---- ScoutClient
// ------------------------------------------------------------

ScoutClient::ScoutClient(ScoutOptions options, ScoutHooks hooks)
    : impl_(std::make_unique<Impl>(std::move(options), std::move(hooks))) {}

ScoutClient::~ScoutClient() = default;

bool ScoutClient::pace() {
  return impl_->uploads_started == 0 || impl_->wait(impl_->options.interval_s);
}

void ScoutClient::upload(const fs::path& photo) { impl_->upload(photo); }

std::size_t ScoutClient::upload_all(const std::vector<fs::path>& photos) {
  std::size_t handled = 0;
  for (const auto& path : photos) {
    if (impl_->stopped() || impl_->totals.refused || !pace()) break;
    impl_->upload(path);
    impl_->done.insert(path.filename().string());
    ++handled;
  }
  return handled;
}

const ScoutTotals& ScoutClient::totals() const { return impl_->totals; }

}  // namespace arscout::scout
