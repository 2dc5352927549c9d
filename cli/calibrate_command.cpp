// `arscout calibrate`: camera intrinsics from photos of a chessboard target
// (the paper's section 3.1), written as the camera document /cameras/{id}
// over the API, straight into a store, or printed.
#include <algorithm>
#include <cctype>
#include <filesystem>
#include <iomanip>
#include <iostream>

#include "arscout/db/path.h"
#include "arscout/db/store.h"
#include "arscout/engine/calibration.h"
#include "arscout/http/client.h"
#include "arscout/util/error.h"
#include "cli_support.h"
#include "command_registry.h"
#include "commands.h"

namespace arscout::cli {
namespace {

namespace fs = std::filesystem;
using db::Json;

struct CalibrateArgs {
  std::string images;
  std::string board;
  double square_m = 0;
  std::string camera_id;
  std::string server;
  std::string token;
  std::string db;
};

void print_calibration(const engine::CameraCalibration& c, int images_seen,
                       std::ostream& out) {
  out << std::fixed << std::setprecision(2) << "calibrated from "
      << c.images_used << " of " << images_seen << " images (" << c.width << "x"
      << c.height << " px):\n"
      << "  focal length  fx " << c.fx << "  fy " << c.fy << " px\n"
      << "  principal pt  cx " << c.cx << "  cy " << c.cy << " px\n"
      << std::setprecision(5) << "  distortion    k1 " << c.k1 << "  k2 "
      << c.k2 << "  p1 " << c.p1 << "  p2 " << c.p2 << "  k3 " << c.k3 << "\n"
      << std::setprecision(3) << "  RMS reprojection error " << c.rms_px
      << " px\n";
  if (c.rms_px > 1.0)
    out << "warning: an RMS error above 1 px suggests blurred photos or a "
           "board that is not flat\n";
  out << std::defaultfloat;
}

// A failed HTTP answer as the error whose kind gives the right exit
// code; the server's JSON error message is kept when there is one.
util::Error http_error(const http::HttpResult& r, const std::string& what) {
  std::string message = r.body;
  try {
    message = r.json().value("message", r.body);
  } catch (const std::exception&) {
    // Not JSON (a proxy's error page, say): the body itself is the message.
  }
  util::ErrorKind kind = util::ErrorKind::kInternal;
  if (r.status == 409) {
    kind = util::ErrorKind::kConflict;
  } else if (r.status == 404) {
    kind = util::ErrorKind::kNotFound;
  } else if (r.status == 502 || r.status == 503 || r.status == 504) {
    kind = util::ErrorKind::kUnavailable;
  } else if (r.status >= 400 && r.status < 500) {
    kind = util::ErrorKind::kInvalidArgument;
  }
  return util::Error(
      kind, what + ": HTTP " + std::to_string(r.status) + ": " + message);
}

void put_over_http(const CalibrateArgs& a, const Json& camera,
                   std::ostream& out) {
  http::ClientOptions options;
  options.server = a.server;
  options.token = a.token;
  http::Client client(options);
  const std::string target = "/v1/cameras/" + a.camera_id;
  http::HttpResult r;
  try {
    r = client.request("PUT", target, camera.dump(),
                       {{"Content-Type", "application/json"}});
  } catch (const http::NetworkError& e) {
    throw util::Error(util::ErrorKind::kUnavailable, e.what());
  }
  if (r.status != 200 && r.status != 201) throw http_error(r, "PUT " + target);
  // The server names it: a scout's camera ids are its own
  // (/cameras/{scout}.{id}, docs/api.md).
  out << "stored " << r.json().value("path", "/cameras/" + a.camera_id)
      << " on " << a.server << " (HTTP " << r.status << ")" << std::endl;
}

void put_in_store(const CalibrateArgs& a, const Json& camera,
                  std::ostream& out) {
  auto store = db::Store::open(a.db);
  auto result = store->put("/cameras/" + a.camera_id, "camera", camera);
  out << "stored " << result.path << " version " << result.version << " in "
      << a.db << std::endl;
}

// Too few usable photos or mixed image sizes are bad input (exit 2), not an
// internal failure.
engine::CameraCalibration calibrate(const std::vector<std::string>& images,
                                    engine::BoardSize board, double square_m,
                                    const engine::ImageStatusCallback& report) {
  try {
    return engine::calibrate_chessboard(images, board, square_m, nullptr,
                                        report);
  } catch (const std::runtime_error& e) {
    throw util::Error(util::ErrorKind::kInvalidArgument, e.what());
  }
}

// The id becomes one path segment and, with --server, part of a URL.
void check_camera_id(const std::string& id) {
  if (id.find('/') != std::string::npos)
    throw util::Error(util::ErrorKind::kInvalidArgument,
                      "--camera-id must be one path segment of "
                      "[A-Za-z0-9._-], not '" +
                          id + "'");
  db::validate_path("/cameras/" + id);
}

int run_calibrate(const CalibrateArgs& a) {
  auto board = engine::parse_board_size(a.board);
  if (!board)
    throw util::Error(util::ErrorKind::kInvalidArgument,
                      "--board must be COLSxROWS inner corners, each 3 to 100 "
                      "(e.g. 9x6), not '" +
                          a.board + "'");
  check_camera_id(a.camera_id);
  // Without a destination the document is the output, so the report goes to
  // stderr and stdout stays clean JSON.
  const bool print_only = a.server.empty() && a.db.empty();
  std::ostream& out = print_only ? std::cerr : std::cout;

  auto images = list_image_files(a.images);
  out << "looking for a chessboard with " << board->cols << "x" << board->rows
      << " inner corners in " << images.size() << " images" << std::endl;
  auto report = [&out](const std::string& path, const std::string& problem) {
    std::string name = fs::path(path).filename().string();
    if (problem.empty()) {
      out << "  board found  " << name << std::endl;
    } else {
      out << "  rejected     " << name << ": " << problem << std::endl;
    }
  };
  auto calibration = calibrate(images, *board, a.square_m, report);
  print_calibration(calibration, static_cast<int>(images.size()), out);

  Json camera = documents::to_json(calibration);
  if (!a.server.empty()) {
    put_over_http(a, camera, out);
  } else if (!a.db.empty()) {
    put_in_store(a, camera, out);
  } else {
    std::cout << camera.dump(2) << std::endl;
  }
  return kExitOk;
}

void add_calibrate_command(CLI::App& app) {
  // CLI11 binds options to storage that outlives parsing.
  static CalibrateArgs args;
  CLI::App* cmd = app.add_subcommand(
      "calibrate",
      "compute a camera's intrinsics from photos of a printed chessboard and "
      "store them as /cameras/ID (via --server or --db; else print the JSON "
      "on stdout)");
  cmd->add_option("--images", args.images,
                  "folder of photos of the board (.jpg .png .tif .bmp), all "
                  "from one camera at one resolution, from varied angles")
      ->required()
      ->check(CLI::ExistingDirectory);
  cmd->add_option("--board", args.board,
                  "INNER corners COLSxROWS, e.g. 9x6 for a board of 10x7 "
                  "squares")
      ->required();
  cmd->add_option("--square", args.square_m, "side of one square in metres")
      ->required()
      ->check(CLI::PositiveNumber);
  cmd->add_option("--camera-id", args.camera_id,
                  "camera id, [A-Za-z0-9._-]: writes /cameras/ID")
      ->required();
  auto* server =
      cmd->add_option("--server", args.server,
                      "API base URL (http[s]://host:port): PUT /v1/cameras/ID");
  cmd->add_option("--token", args.token, "API bearer token (with --server)")
      ->needs(server);
  cmd->add_option("--db", args.db,
                  "write straight into this store (sqlite:FILE or "
                  "postgresql://...)")
      ->excludes(server);
  cmd->callback([] { run_command([] { return run_calibrate(args); }); });
}

const CommandRegistration calibrate_command_registration(40,
                                                         add_calibrate_command);

}  // namespace
}  // namespace arscout::cli
