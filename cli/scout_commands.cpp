// `arscout scout`, `arscout sites`, `arscout get`: the HTTP API's client side
// (docs/api.md). `scout` walks a folder of photos like a scout walking a
// site, uploading each with its GPS fix; the others read what is there.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "arscout/db/path.h"
#include "arscout/engine/camera.h"
#include "arscout/engine/image_size.h"
#include "arscout/http/client.h"
#include "arscout/scout/scout.h"
#include "arscout/util/error.h"
#include "arscout/util/file.h"
#include "cli_support.h"
#include "command_registry.h"
#include "commands.h"
#include "scout_overlay.h"

namespace arscout::cli {
namespace {

namespace fs = std::filesystem;
using http::Client;
using http::HttpResult;
using Json = nlohmann::json;

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

http::ClientOptions client_options(const ServerArgs& a) {
  http::ClientOptions o;
  o.server = a.server;
  o.token = a.token;
  o.timeout = std::chrono::milliseconds(std::llround(a.timeout_s * 1000));
  o.verify_tls = !a.insecure;
  o.ca_file = a.ca_file;
  return o;
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
  std::cerr << "arscout: error (HTTP " << r.status
            << "): " << scout::answer_error_text(r) << "\n";
  return exit_code_for_status(r.status);
}

// Like run_command, with an unreachable server as kExitUnavailable.
void run_client_command(const std::function<int()>& body) {
  run_command([&] {
    try {
      return body();
    } catch (const http::NetworkError& e) {
      std::cerr << "arscout: error (unavailable): " << e.what() << "\n";
      return static_cast<int>(kExitUnavailable);
    }
  });
}

// ---- scout
// ---------------------------------------------------------------------

// The options as CLI11 binds them; the upload client itself is
// scout::ScoutClient (arscout/scout/scout.h).
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
  bool wait_verdicts = false;
};

scout::ScoutOptions scout_options(const ScoutArgs& a) {
  scout::ScoutOptions o;
  o.client = client_options(a.server);
  o.gps_csv = a.gps_csv;
  o.gpx = a.gpx;
  if (a.time_offset_given) o.time_offset_s = a.time_offset_s;
  o.gpx_max_gap_s = a.gpx_max_gap_s;
  o.interval_s = a.interval_s;
  o.site_hint = a.site_hint;
  o.camera = a.camera;
  o.scout_name = a.scout_name;
  o.retries = a.retries;
  return o;
}

// --camera-k: the camera document /cameras/{--camera} from a 3x3 K (the
// Strecha K.txt layout), for photos of the first photo's size; stored
// before any upload so that the engine finds it with the first capture.
// Here rather than in ingest, which does not link the engine.
int put_camera_from_k(const ScoutArgs& a, const fs::path& first_photo) {
  std::optional<engine::ImageSize> size;
  try {
    size = engine::read_image_size(util::read_file(first_photo.string()));
  } catch (const std::runtime_error&) {  // reported as no size below
  }
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
  k.source = "calibrated";
  const Json camera = documents::to_json(k);
  http::Client client(client_options(a.server));
  const std::string target = "/v1/cameras/" + a.camera;
  const auto r = client.request("PUT", target, camera.dump(),
                                {{"Content-Type", "application/json"}});
  if (r.status != 200 && r.status != 201) {
    std::cerr << "arscout scout: PUT " << target << ": HTTP " << r.status
              << ": " << r.body << "\n";
    return r.status == 401 || r.status == 403 ? kExitError : kExitUsage;
  }
  std::cout << "camera " << r.json().value("path", a.camera) << ": " << k.width
            << "x" << k.height << ", f " << k.fx << " px (from " << a.camera_k
            << ")" << std::endl;
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
  std::unique_ptr<VerdictWatcher> verdicts;
  scout::ScoutHooks hooks;
  hooks.stop_requested = stop_requested;
  hooks.on_stored = [&verdicts](const std::string& id,
                                const std::string& name) {
    verdicts->add(id, name);
  };
  // First: a bad GPS file is reported before anything else is done.
  scout::ScoutClient scout(scout_options(a), hooks);
  verdicts = std::make_unique<VerdictWatcher>(
      client_options(a.server), a.overlay_dir, a.overlay_timeout_s);
  const auto photos = a.dir.empty() ? scout::sorted_by_file_name(a.files)
                                    : scout::list_photos(a.dir, std::cerr);
  if (photos.empty() && !a.watch) {
    std::cerr << "arscout scout: no .jpg/.jpeg/.png photos in " << a.dir
              << "\n";
    return kExitUsage;
  }
  if (!a.camera_k.empty() && !photos.empty()) {
    if (int code = put_camera_from_k(a, photos.front()); code != kExitOk)
      return code;
  }
  const std::size_t handled = scout.upload_all(photos);
  if (a.watch && !stop_requested() && !scout.totals().refused)
    scout.watch(a.dir);

  if (!a.overlay_dir.empty()) {
    const int saved = verdicts->finish();
    std::cout << saved << " overlays saved in " << a.overlay_dir << std::endl;
  } else if (a.wait_verdicts) {
    verdicts->finish();
  }
  verdicts.reset();  // no more verdict lines after the summary
  const std::size_t left_over = a.watch ? 0 : photos.size() - handled;
  std::cout << scout::scout_summary(scout.totals(), left_over) << std::endl;
  return scout.totals().failed == 0 && left_over == 0 ? kExitOk : kExitError;
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
                  "seconds to wait for a photo to be registered (its verdict "
                  "line, its overlay)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->add_flag("--wait", a.wait_verdicts,
                "after the last upload, wait for every photo's verdict "
                "(registered with its model version, or why not; at most "
                "--overlay-timeout s after its upload); --overlay waits too");
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
    throw util::Error(util::ErrorKind::kInvalidArgument,
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

void add_scout_get(CLI::App& app) {
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
  add_scout_get(app);
}

const CommandRegistration scout_commands_registration(30, add_scout_commands);

}  // namespace
}  // namespace arscout::cli
