// `arscout scout`, `arscout sites`, `arscout get`: the HTTP API's client side
// (docs/api.md). `scout` walks a folder of photos like a scout walking a
// site, uploading each with its GPS fix; the others read what is there.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "arscout/db/errors.h"
#include "arscout/db/path.h"
#include "arscout/engine/camera.h"
#include "arscout/engine/image_size.h"
#include "arscout/ingest/client.h"
#include "arscout/ingest/gps.h"
#include "cli_support.h"
#include "command_registry.h"
#include "commands.h"
#include "scout_overlay.h"

namespace arscout::cli {
namespace {

namespace fs = std::filesystem;
using ingest::Client;
using ingest::GpsFix;
using ingest::HttpResult;
using ingest::Json;

// ---- shared: server options, answers, errors
// ----------------------------------

struct ServerArgs {
  std::string server;
  std::string token;
  double timeout_s = 60;
  bool insecure = false;
  std::string ca_file;
};

void add_server_options(CLI::App& cmd, ServerArgs& a) {
  cmd.add_option("--server", a.server,
                 "API base URL: http://HOST:PORT or https://HOST:PORT")
      ->required();
  cmd.add_option("--token", a.token, "API token (or set ARSCOUT_TOKEN)")
      ->envname("ARSCOUT_TOKEN")
      ->required();
  cmd.add_option("--timeout", a.timeout_s,
                 "seconds allowed per request, connecting included")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd.add_flag("--insecure", a.insecure,
               "do not verify the server's TLS certificate");
  cmd.add_option("--ca-file", a.ca_file, "extra CA certificate (PEM) to trust")
      ->check(CLI::ExistingFile);
}

ingest::ClientOptions client_options(const ServerArgs& a) {
  ingest::ClientOptions o;
  o.server = a.server;
  o.token = a.token;
  o.timeout = std::chrono::milliseconds(std::llround(a.timeout_s * 1000));
  o.verify_tls = !a.insecure;
  o.ca_file = a.ca_file;
  return o;
}

// "kind: message" from the API's JSON error body, else the start of the body.
std::string error_text(const HttpResult& r) {
  try {
    Json j = r.json();
    if (j.is_object() && j.contains("error"))
      return j.value("error", "") + ": " + j.value("message", "");
  } catch (const std::exception&) {  // not the API's error form
  }
  std::string text = "HTTP " + std::to_string(r.status);
  if (!r.body.empty()) text += ": " + r.body.substr(0, 200);
  return text;
}

int exit_code_for_status(int status) {
  switch (status) {
    case 400:
    case 422:
      return kExitUsage;
    case 404:
      return kExitNotFound;
    case 409:
      return kExitConflict;
    case 503:
      return kExitUnavailable;
    default:
      return kExitError;
  }
}

int report_error_answer(const HttpResult& r) {
  std::cerr << "arscout: error (HTTP " << r.status << "): " << error_text(r)
            << "\n";
  return exit_code_for_status(r.status);
}

// Like run_command, with an unreachable server as kExitUnavailable.
void run_client_command(const std::function<int()>& body) {
  run_command([&] {
    try {
      return body();
    } catch (const ingest::NetworkError& e) {
      std::cerr << "arscout: error (unavailable): " << e.what() << "\n";
      return static_cast<int>(kExitUnavailable);
    }
  });
}

// Sleeps up to `seconds`; false when SIGINT/SIGTERM cut it short.
bool sleep_unless_stopped(double seconds) {
  auto until = std::chrono::steady_clock::now() +
               std::chrono::milliseconds(std::llround(seconds * 1000));
  while (!stop_requested()) {
    auto left = until - std::chrono::steady_clock::now();
    if (left <= std::chrono::steady_clock::duration::zero()) return true;
    std::this_thread::sleep_for(std::min<std::chrono::steady_clock::duration>(
        left, std::chrono::milliseconds(100)));
  }
  return false;
}

// FNV-1a: a stable short hash with no dependency (std::hash may change).
std::string short_hash(std::string_view s, int hex_digits) {
  std::uint64_t h = 14695981039346656037ull;
  for (unsigned char c : s) h = (h ^ c) * 1099511628211ull;
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
  return std::string(buf, hex_digits);
}

// ---- photos and capture ids
// ----------------------------------------------------

std::string lower(std::string s) {
  for (char& c : s)
    c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// Hidden files are skipped: "._IMG_0001.jpg" is macOS metadata, not a photo.
bool is_photo_name(const fs::path& path) {
  std::string name = path.filename().string();
  std::string ext = lower(path.extension().string());
  return !name.starts_with('.') &&
         (ext == ".jpg" || ext == ".jpeg" || ext == ".png");
}

void sort_by_file_name(std::vector<fs::path>& files) {
  std::stable_sort(files.begin(), files.end(),
                   [](const fs::path& a, const fs::path& b) {
                     return a.filename().string() < b.filename().string();
                   });
}

// The photos directly in dir, in file-name order; a folder that cannot be
// read (yet, or any more, while watching) has none.
std::vector<fs::path> list_photos(const std::string& dir) {
  std::vector<fs::path> photos;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end;
       it.increment(ec)) {
    if (it->is_regular_file(ec) && is_photo_name(it->path()))
      photos.push_back(it->path());
  }
  if (ec)
    std::cerr << "arscout: cannot list " << dir << ": " << ec.message() << "\n";
  sort_by_file_name(photos);
  return photos;
}

std::string sanitise(std::string_view s) {
  std::string out(s);
  for (char& c : out)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '.' && c != '-' &&
        c != '_')
      c = '_';
  return out;
}

// Deterministic, so that a retry or a re-run of the same folder is replayed
// by the server instead of stored twice. The server keeps every id under
// the token's name ("{name}.{id}", docs/api.md), so it need not be unique
// across scouts: "{--scout-name}.{file}", kept as it is when --scout-name
// is the token's name.
std::string capture_id(const std::string& prefix, const std::string& file) {
  std::string id =
      (prefix.empty() ? "" : sanitise(prefix) + ".") + sanitise(file);
  constexpr std::size_t kMax = 128;
  if (id.size() > kMax) id = id.substr(0, kMax - 13) + "-" + short_hash(id, 12);
  return id;
}

std::optional<std::string> read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return std::nullopt;
  std::ostringstream out;
  out << in.rdbuf();
  if (in.bad()) return std::nullopt;
  return out.str();
}

// By magic number; the extension only when the bytes are neither (the server
// then says what is wrong with them).
std::string content_type(const std::string& bytes, const fs::path& path) {
  if (bytes.starts_with("\x89PNG")) return "image/png";
  if (bytes.starts_with("\xFF\xD8\xFF")) return "image/jpeg";
  return lower(path.extension().string()) == ".png" ? "image/png"
                                                    : "image/jpeg";
}

// ---- scout
// ---------------------------------------------------------------------

struct ScoutArgs {
  ServerArgs server;
  std::string dir;
  std::vector<std::string> files;
  std::string gps_csv;
  std::string gpx;
  double time_offset_s = 0;
  bool time_offset_given = false;
  double gpx_max_gap_s = 60;
  double interval_s = 0;
  bool watch = false;
  std::string site_hint;
  std::string camera;
  std::string camera_k;
  std::string scout_name;
  int retries = 8;
  std::string overlay_dir;
  double overlay_timeout_s = 120;
};

// Where a photo's request GPS comes from: a CSV row by file name, a GPX track
// by the EXIF capture time, or nowhere (the server then reads the EXIF GPS).
class GpsSource {
 public:
  explicit GpsSource(const ScoutArgs& a) : a_(a) {
    if (!a.gps_csv.empty()) csv_ = ingest::read_gps_csv(a.gps_csv);
    if (!a.gpx.empty()) track_ = ingest::read_gpx(a.gpx);
  }

  // nullopt with *why when the file gives no fix for this photo.
  std::optional<GpsFix> fix_for(const std::string& file_name,
                                const ingest::ExifInfo& exif,
                                std::string* why) const {
    if (!a_.gps_csv.empty()) return from_csv(file_name, why);
    if (!a_.gpx.empty()) return from_gpx(exif, why);
    return std::nullopt;
  }

  // EXIF DateTimeOriginal as UTC seconds: the camera clock is taken as UTC
  // unless --time-offset says how far ahead of UTC it runs.
  std::optional<std::int64_t> taken_utc(const ingest::ExifInfo& exif) const {
    auto t = ingest::parse_time_utc(exif.taken);
    if (!t) return std::nullopt;
    return *t - std::llround(a_.time_offset_s);
  }

 private:
  std::optional<GpsFix> from_csv(const std::string& file_name,
                                 std::string* why) const {
    auto it = csv_.find(file_name);
    if (it != csv_.end()) return it->second;
    *why = "no row in " + fs::path(a_.gps_csv).filename().string();
    return std::nullopt;
  }

  std::optional<GpsFix> from_gpx(const ingest::ExifInfo& exif,
                                 std::string* why) const {
    auto t = taken_utc(exif);
    if (!t) {
      *why = "no EXIF DateTimeOriginal to match the GPX track";
      return std::nullopt;
    }
    auto fix = ingest::fix_at(track_, *t, std::llround(a_.gpx_max_gap_s));
    if (!fix) *why = "taken " + ingest::format_time_utc(*t) + ", off the track";
    return fix;
  }

  const ScoutArgs& a_;
  std::map<std::string, GpsFix> csv_;
  std::vector<ingest::TrackPoint> track_;
};

// "csv ±2.1 m 8 sat" from a fix in its JSON form.
std::string describe_gps(const Json& gps) {
  std::ostringstream out;
  out << gps.value("source", "?");
  out.setf(std::ios::fixed);
  out.precision(1);
  if (auto it = gps.find("h_acc"); it != gps.end() && it->is_number())
    out << " ±" << it->get<double>() << " m";
  if (auto it = gps.find("satellites"); it != gps.end() && it->is_number())
    out << " " << it->get<int>() << " sat";
  return out.str();
}

// What one upload ended with.
struct UploadOutcome {
  std::optional<HttpResult> answer;
  std::string error;  // the last network error when there is no answer
  int attempts = 0;
  double round_trip_ms = 0;  // of the last attempt
};

bool retryable(int status) {
  return status >= 500 || status == 408 || status == 429;
}

// 0.5 s doubling to 8 s, or longer when a 503 says Retry-After.
double backoff_s(int retry, const std::optional<HttpResult>& answer) {
  double delay = std::min(0.5 * std::pow(2.0, retry), 8.0);
  if (answer) {
    auto it = answer->headers.find("retry-after");
    if (it != answer->headers.end()) {
      double after = std::atof(it->second.c_str());
      if (after > delay) delay = std::min(after, 60.0);
    }
  }
  return delay;
}

// One photo, start to end: read, find its fix, upload with retries, print.
class Uploader {
 public:
  explicit Uploader(const ScoutArgs& a)
      : a_(a),
        client_(client_options(a.server)),
        gps_(a),
        prefix_(a.scout_name) {}

  // Waits --interval after the previous photo; false when interrupted.
  bool pace() {
    return uploads_started_ == 0 || sleep_unless_stopped(a_.interval_s);
  }

  void upload(const fs::path& path) {
    ++uploads_started_;
    std::string name = path.filename().string();
    if (!is_photo_name(path)) return fail(name, "not a .jpg/.jpeg/.png file");
    auto bytes = read_bytes(path);
    if (!bytes) return fail(name, "cannot read " + path.string());
    send(name, *bytes, path);
  }

  // Called with (capture id, file name) for every photo the server took.
  void on_stored(
      std::function<void(const std::string&, const std::string&)> f) {
    on_stored_ = std::move(f);
  }

  int succeeded() const { return succeeded_; }
  // The server refused the token or its role: later photos would be too.
  bool refused() const { return refused_; }
  int failed() const { return failed_; }
  std::uint64_t bytes_sent() const { return bytes_sent_; }

 private:
  void send(const std::string& name, const std::string& bytes,
            const fs::path& path) {
    auto exif = ingest::read_exif(bytes);
    std::string why;
    auto fix = gps_.fix_for(name, exif, &why);
    std::string id = capture_id(prefix_, name);
    Json meta = metadata(id, name, fix, exif);
    std::vector<std::pair<std::string, std::string>> headers{
        {"Content-Type", content_type(bytes, path)},
        {"X-Capture-Metadata", meta.dump(-1, ' ', true)}};
    auto outcome = post_with_retries(name, bytes, headers);
    report(name, id, bytes.size(), planned_gps(fix, exif), why, outcome);
    if (outcome.answer &&
        (outcome.answer->status == 401 || outcome.answer->status == 403))
      refused_ = true;
  }

  Json metadata(const std::string& id, const std::string& name,
                const std::optional<GpsFix>& fix,
                const ingest::ExifInfo& exif) const {
    Json meta{{"capture_id", id}, {"filename", name}};
    if (fix) {
      meta["gps"] = ingest::to_json(*fix);
      meta["gps"].erase("source");  // the server records "request"
    }
    if (!a_.camera.empty()) meta["camera"] = a_.camera;
    if (!a_.site_hint.empty()) meta["site_hint"] = a_.site_hint;
    // Without an offset the server keeps EXIF's zone-less local time.
    if (auto t = gps_.taken_utc(exif); t && a_.time_offset_given)
      meta["taken"] = ingest::format_time_utc(*t);
    return meta;
  }

  // Before the answer says which fix the server kept: ours, else EXIF's.
  static std::string planned_gps(const std::optional<GpsFix>& fix,
                                 const ingest::ExifInfo& exif) {
    if (fix) return describe_gps(ingest::to_json(*fix));
    return exif.gps ? describe_gps(ingest::to_json(*exif.gps)) : "none";
  }

  UploadOutcome post_with_retries(
      const std::string& name, const std::string& bytes,
      const std::vector<std::pair<std::string, std::string>>& headers) {
    UploadOutcome out;
    for (int retry = 0;; ++retry) {
      attempt(bytes, headers, &out);
      if (out.answer && !retryable(out.answer->status)) return out;
      if (retry >= a_.retries || stop_requested()) return out;
      double delay = backoff_s(retry, out.answer);
      std::cerr << "  " << name << ": "
                << (out.answer ? error_text(*out.answer) : out.error)
                << "; retry " << retry + 1 << "/" << a_.retries << " in "
                << delay << " s\n";
      if (!sleep_unless_stopped(delay)) return out;
    }
  }

  void attempt(const std::string& bytes,
               const std::vector<std::pair<std::string, std::string>>& headers,
               UploadOutcome* out) {
    ++out->attempts;
    auto start = std::chrono::steady_clock::now();
    try {
      out->answer = client_.request("POST", "/v1/captures", bytes, headers);
    } catch (const ingest::NetworkError& e) {
      out->answer.reset();
      out->error = e.what();
    }
    out->round_trip_ms = std::chrono::duration<double, std::milli>(
                             std::chrono::steady_clock::now() - start)
                             .count();
  }

  // `why` says why the GPS file had no fix for the photo.
  void report(const std::string& name, const std::string& id, std::size_t size,
              const std::string& gps_text, const std::string& why,
              const UploadOutcome& out) {
    std::ostringstream line;
    line << name << "  gps ";
    bool ok = out.answer && out.answer->status / 100 == 2;
    if (ok) {
      const std::string stored = stored_id(*out.answer, id);
      line << accepted(*out.answer, stored, gps_text, why);
      ++succeeded_;
      if (on_stored_) on_stored_(stored, name);
      bytes_sent_ += size;
    } else {
      line << gps_text << (why.empty() ? "" : " (" + why + ")") << "  "
           << (out.answer ? std::to_string(out.answer->status) + " " +
                                error_text(*out.answer)
                          : "network error: " + out.error);
      ++failed_;
    }
    line << "  " << size << " B  " << std::llround(out.round_trip_ms) << " ms";
    if (out.attempts > 1) line << "  (" << out.attempts << " attempts)";
    std::cout << line.str() << std::endl;
  }

  // The id the server stored the capture under (its document's path), else
  // the one sent.
  static std::string stored_id(const HttpResult& answer,
                               const std::string& sent) {
    try {
      const std::string path = answer.json().value("path", "");
      if (path.rfind("/captures/", 0) == 0) return path.substr(10);
    } catch (const std::exception&) {
    }
    return sent;
  }

  // "exif ±25.0 m  201 alice.01.jpg seq 17 stored  model v3" for an answer.
  std::string accepted(const HttpResult& answer, const std::string& id,
                       const std::string& gps_text, const std::string& why) {
    std::ostringstream text;
    Json doc;
    try {
      doc = answer.json();
    } catch (const std::exception&) {
      text << gps_text << "  " << answer.status << " " << id
           << " (unreadable answer)";
      return text.str();
    }
    Json attrs = doc.value("attrs", Json::object());
    // "request" says less than our own description (csv or gpx).
    auto gps = attrs.find("gps");
    bool has_gps = gps != attrs.end() && gps->is_object();
    if (has_gps && gps->value("source", "") == "request")
      text << gps_text;
    else
      text << (has_gps ? describe_gps(*gps) : "none");
    text << (why.empty() ? "" : " (" + why + ")") << "  " << answer.status;
    if (answer.headers.count("idempotent-replay")) text << " replay";
    text << " " << id << " seq " << doc.value("seq", Json()).dump() << " "
         << attrs.value("status", "?");
    if (auto model = model_version(attrs)) text << "  " << *model;
    return text.str();
  }

  // "site S model vN" when the engine has placed the capture in a site that
  // has a model; nothing otherwise (a failed lookup does not fail the photo).
  std::optional<std::string> model_version(const Json& attrs) {
    std::string site = attrs.value("site", "");
    if (site.empty() || sanitise(site) != site) return std::nullopt;
    try {
      auto answer = client_.get("/v1/docs/sites/" + site + "/model");
      if (answer.status != 200) return std::nullopt;
      return "site " + site + " model v" +
             answer.json().value("version", Json()).dump();
    } catch (const std::exception&) {
      return std::nullopt;
    }
  }

  void fail(const std::string& name, const std::string& why) {
    std::cout << name << "  " << why << std::endl;
    ++failed_;
  }

  const ScoutArgs& a_;
  Client client_;
  GpsSource gps_;
  std::string prefix_;
  std::function<void(const std::string&, const std::string&)> on_stored_;
  int uploads_started_ = 0;
  bool refused_ = false;
  int succeeded_ = 0;
  int failed_ = 0;
  std::uint64_t bytes_sent_ = 0;
};

// A file's size and modification time, to see when a new one is complete.
using FileSignature = std::pair<std::uintmax_t, fs::file_time_type>;

std::optional<FileSignature> signature(const fs::path& path) {
  std::error_code ec1, ec2;
  auto size = fs::file_size(path, ec1);
  auto time = fs::last_write_time(path, ec2);
  if (ec1 || ec2) return std::nullopt;
  return FileSignature{size, time};
}

// Polls the folder each second until SIGINT/SIGTERM. A new file is uploaded
// once it looks the same on two polls in a row, so a photo still being
// copied in is not sent half-written.
void watch_folder(const std::string& dir, std::set<std::string>& done,
                  Uploader& uploader) {
  std::cerr << "watching " << dir << " for new photos (Ctrl-C to stop)\n";
  std::map<std::string, FileSignature> pending;
  while (sleep_unless_stopped(1.0)) {
    for (const auto& path : list_photos(dir)) {
      std::string name = path.filename().string();
      auto sig = signature(path);
      if (done.count(name) || !sig) continue;
      auto it = pending.find(name);
      if (it == pending.end() || it->second != *sig) {
        pending[name] = *sig;
        continue;
      }
      if (!uploader.pace()) return;
      pending.erase(it);
      done.insert(name);
      uploader.upload(path);
      if (stop_requested() || uploader.refused()) return;
    }
  }
}

std::vector<fs::path> initial_photos(const ScoutArgs& a) {
  if (!a.dir.empty()) return list_photos(a.dir);
  std::vector<fs::path> files(a.files.begin(), a.files.end());
  sort_by_file_name(files);
  return files;
}

// --camera-k: the camera document /cameras/{--camera} from a 3x3 K (the
// Strecha K.txt layout), for photos of the first photo's size; stored
// before any upload so that the engine finds it with the first capture.
int put_camera_from_k(const ScoutArgs& a, const fs::path& first_photo) {
  const auto bytes = read_bytes(first_photo);
  const auto size = bytes ? engine::read_image_size(*bytes) : std::nullopt;
  if (!size) {
    std::cerr << "arscout scout: cannot read the size of " << first_photo
              << " for --camera-k\n";
    return kExitUsage;
  }
  engine::CameraIntrinsics k;
  try {
    k = engine::read_k_matrix(a.camera_k, size->width, size->height);
  } catch (const std::exception& e) {
    std::cerr << "arscout scout: " << e.what() << "\n";
    return kExitUsage;
  }
  const Json camera = {{"fx", k.fx},
                       {"fy", k.fy},
                       {"cx", k.cx},
                       {"cy", k.cy},
                       {"width", k.width},
                       {"height", k.height},
                       {"distortion", {0, 0, 0, 0, 0}},
                       {"source", "calibrated"}};
  ingest::Client client(client_options(a.server));
  const std::string target = "/v1/cameras/" + a.camera;
  const auto r = client.request("PUT", target, camera.dump(),
                                {{"Content-Type", "application/json"}});
  if (r.status != 200 && r.status != 201) {
    std::cerr << "arscout scout: PUT " << target << ": HTTP " << r.status
              << ": " << r.body << "\n";
    return r.status == 401 || r.status == 403 ? kExitError : kExitUsage;
  }
  std::cout << "camera " << a.camera << ": " << k.width << "x" << k.height
            << ", f " << k.fx << " px (from " << a.camera_k << ")" << std::endl;
  return kExitOk;
}

int run_scout(const ScoutArgs& a) {
  if (a.dir.empty() == a.files.empty()) {
    std::cerr << "arscout scout: give either --dir DIR or photo FILES\n";
    return kExitUsage;
  }
  if (!a.camera_k.empty() && a.camera.empty()) {
    std::cerr << "arscout scout: --camera-k needs --camera ID\n";
    return kExitUsage;
  }
  install_stop_handlers();
  Uploader uploader(a);
  std::unique_ptr<OverlaySaver> overlays;
  if (!a.overlay_dir.empty()) {
    overlays = std::make_unique<OverlaySaver>(
        client_options(a.server), a.overlay_dir, a.overlay_timeout_s);
    uploader.on_stored([&](const std::string& id, const std::string& name) {
      overlays->add(id, name);
    });
  }
  auto photos = initial_photos(a);
  if (photos.empty() && !a.watch) {
    std::cerr << "arscout scout: no .jpg/.jpeg/.png photos in " << a.dir
              << "\n";
    return kExitUsage;
  }
  if (!a.camera_k.empty() && !photos.empty()) {
    if (int code = put_camera_from_k(a, photos.front()); code != kExitOk)
      return code;
  }
  std::set<std::string> done;
  std::size_t handled = 0;
  for (const auto& path : photos) {
    if (stop_requested() || uploader.refused() || !uploader.pace()) break;
    uploader.upload(path);
    done.insert(path.filename().string());
    ++handled;
  }
  if (a.watch && !stop_requested() && !uploader.refused())
    watch_folder(a.dir, done, uploader);

  if (overlays) {
    const int saved = overlays->finish();
    std::cout << saved << " overlays saved in " << a.overlay_dir << std::endl;
  }
  int total = uploader.succeeded() + uploader.failed();
  bool interrupted = !a.watch && handled < photos.size();
  std::cout << uploader.succeeded() << " of " << total << " photos uploaded ("
            << uploader.bytes_sent() << " B), " << uploader.failed()
            << " failed";
  if (interrupted)
    std::cout << (uploader.refused() ? ", token refused" : ", interrupted")
              << " before " << photos.size() - handled << " more";
  std::cout << std::endl;
  return uploader.failed() == 0 && !interrupted ? kExitOk : kExitError;
}

void add_scout(CLI::App& app) {
  static ScoutArgs a;  // CLI11 binds options to storage that outlives parsing
  CLI::App* cmd = app.add_subcommand(
      "scout",
      "upload photos as POST /v1/captures, one by one in file-name order, "
      "each with its GPS fix and an idempotent capture id");
  add_server_options(*cmd, a.server);
  auto* dir = cmd->add_option("--dir", a.dir, "folder of .jpg/.jpeg/.png")
                  ->check(CLI::ExistingDirectory);
  auto* files = cmd->add_option("files", a.files, "photos to upload")
                    ->check(CLI::ExistingFile);
  dir->excludes(files);
  auto* csv =
      cmd->add_option("--gps-csv", a.gps_csv,
                      "fixes by file name: image,latitude,longitude,altitude,"
                      "horizontal_accuracy_m,vertical_accuracy_m");
  csv->check(CLI::ExistingFile);
  cmd->add_option("--gpx", a.gpx,
                  "GPX track matched by each photo's EXIF DateTimeOriginal")
      ->check(CLI::ExistingFile)
      ->excludes(csv);
  cmd->add_option("--time-offset", a.time_offset_s,
                  "seconds the camera clock runs ahead of UTC (3600 for "
                  "CET); default: the EXIF time is UTC")
      ->each([](const std::string&) { a.time_offset_given = true; });
  cmd->add_option("--gpx-max-gap", a.gpx_max_gap_s,
                  "seconds a photo may be taken before or after the track")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--interval", a.interval_s, "seconds to wait between photos")
      ->check(CLI::NonNegativeNumber);
  cmd->add_flag("--watch", a.watch,
                "keep uploading new photos that appear in --dir until "
                "interrupted")
      ->needs(dir);
  cmd->add_option("--site-hint", a.site_hint, "site the photos belong to");
  cmd->add_option("--camera", a.camera, "camera id (a /cameras/{id})");
  cmd->add_option("--camera-k", a.camera_k,
                  "store /cameras/{--camera} first, from a 3x3 K matrix "
                  "file (as ../shared/data/strecha/*/images/K.txt)")
      ->check(CLI::ExistingFile);
  cmd->add_option("--scout-name", a.scout_name,
                  "capture id prefix (the server keeps every id under the "
                  "token's name anyway)");
  cmd->add_option("--retries", a.retries,
                  "retries of a network error or 5xx answer, 0.5 s doubling "
                  "to 8 s apart")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--overlay", a.overlay_dir,
                  "save each photo's AR overlay (the site's model drawn over "
                  "it) as DIR/NAME.overlay.jpg once the engine registers it");
  cmd->add_option("--overlay-timeout", a.overlay_timeout_s,
                  "seconds to wait for a photo to be registered")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->callback([] { run_client_command([] { return run_scout(a); }); });
}

// ---- sites, get
// -----------------------------------------------------------------

struct SitesArgs {
  ServerArgs server;
  std::string near;
  double radius_m = -1;
};

// "LAT,LON" -> "LAT,LON" normalised, or throws a usage error.
std::string parse_near(const std::string& text) {
  double lat = NAN, lon = NAN;
  char extra;
  if (std::sscanf(text.c_str(), "%lf,%lf%c", &lat, &lon, &extra) != 2 ||
      !(lat >= -90 && lat <= 90) || !(lon >= -180 && lon <= 180))
    throw db::StoreError(db::ErrorCode::kInvalidArgument,
                         "--near wants LAT,LON in degrees, got '" + text + "'");
  std::ostringstream out;
  out.precision(10);
  out << lat << "," << lon;
  return out.str();
}

int run_sites(const SitesArgs& a) {
  std::string target = "/v1/sites";
  if (!a.near.empty()) {
    target += "?near=" + parse_near(a.near);
    if (a.radius_m >= 0) target += "&radius=" + std::to_string(a.radius_m);
  }
  Client client(client_options(a.server));
  auto answer = client.get(target);
  if (answer.status != 200) return report_error_answer(answer);
  for (const auto& site : answer.json().value("sites", Json::array()))
    std::cout << site.dump() << "\n";
  std::cout.flush();
  return kExitOk;
}

void add_sites(CLI::App& app) {
  static SitesArgs a;
  CLI::App* cmd = app.add_subcommand(
      "sites",
      "list the sites near a place (all without --near), one JSON "
      "line each");
  add_server_options(*cmd, a.server);
  cmd->add_option("--near", a.near, "LAT,LON in degrees");
  cmd->add_option("--radius", a.radius_m,
                  "metres around --near (default: the server's, 1000)")
      ->check(CLI::NonNegativeNumber);
  cmd->callback([] { run_client_command([] { return run_sites(a); }); });
}

struct GetArgs {
  ServerArgs server;
  std::string path;
  int depth = -1;
};

int run_get(const GetArgs& a) {
  db::validate_path(a.path, /*root_ok=*/a.depth >= 0);
  std::string target = "/v1/docs" + a.path;
  if (a.depth >= 0) target += "?depth=" + std::to_string(a.depth);
  Client client(client_options(a.server));
  auto answer = client.get(target);
  if (answer.status != 200) return report_error_answer(answer);
  Json doc = answer.json();
  if (a.depth < 0) {
    std::cout << doc.dump(2) << std::endl;
    return kExitOk;
  }
  for (const auto& d : doc.value("documents", Json::array()))
    std::cout << d.dump() << "\n";
  std::cout.flush();
  return kExitOk;
}

void add_get(CLI::App& app) {
  static GetArgs a;
  CLI::App* cmd = app.add_subcommand(
      "get",
      "print a document from the server as JSON; with --depth, its subtree "
      "as one JSON line per document");
  add_server_options(*cmd, a.server);
  cmd->add_option("path", a.path, "document path, e.g. /captures/alice-01.jpg")
      ->required();
  cmd->add_option("--depth", a.depth, "levels below path to include (>= 0)")
      ->check(CLI::NonNegativeNumber);
  cmd->callback([] { run_client_command([] { return run_get(a); }); });
}

void add_scout_commands(CLI::App& app) {
  add_scout(app);
  add_sites(app);
  add_get(app);
}

const CommandRegistration registration(30, add_scout_commands);

}  // namespace
}  // namespace arscout::cli
