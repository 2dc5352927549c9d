// `arscout render`: draws a model's point cloud offline (CPU, z-buffer, no
// GPU) from one of its cameras or from an orbit view, for reports and
// tests.
#include <cctype>
#include <filesystem>
#include <iostream>

#include <Eigen/Geometry>
#include <opencv2/imgcodecs.hpp>

#include "arscout/engine/model_io.h"
#include "arscout/engine/point_render.h"
#include "arscout/util/error.h"
#include "cli_support.h"
#include "command_registry.h"
#include "commands.h"

namespace arscout::cli {
namespace {

namespace fs = std::filesystem;

struct RenderArgs {
  std::string model;
  std::string view;
  bool orbit = false;
  double azimuth = 30;
  double elevation = 30;
  int width = 0;
  int height = 0;
  int radius = 1;
  std::string output;
};

util::Error bad(const std::string& what) {
  return util::Error(util::ErrorKind::kInvalidArgument, what);
}

// The cloud to draw: FILE.ply itself, or in a model folder its dense.ply,
// else its sparse.ply, else the COLMAP model's points.
std::vector<engine::ColoredPoint> model_points(
    const fs::path& path, const std::optional<engine::Model>& model) {
  if (fs::is_regular_file(path)) return engine::read_ply(path.string());
  for (const char* name : {"dense.ply", "sparse.ply"})
    if (fs::exists(path / name))
      return engine::read_ply((path / name).string());
  std::vector<engine::ColoredPoint> points;
  if (model)
    for (const engine::ModelPoint& p : model->points)
      points.push_back(
          {static_cast<float>(p.xyz[0]), static_cast<float>(p.xyz[1]),
           static_cast<float>(p.xyz[2]), p.rgb[0], p.rgb[1], p.rgb[2]});
  return points;
}

// The COLMAP text model in a folder (or its sparse/), if there is one.
std::optional<engine::Model> colmap_model(const fs::path& path) {
  if (!fs::is_directory(path)) return std::nullopt;
  for (const fs::path& dir : {path, path / "sparse"})
    if (fs::exists(dir / "images.txt"))
      return engine::read_colmap_text(dir.string());
  return std::nullopt;
}

// The camera of image `name` (its file name, or any unique suffix of it),
// scaled to `width` pixels wide when given.
engine::PinholeView camera_view(const engine::Model& model,
                                const std::string& name, int width) {
  const engine::ModelImage* found = nullptr;
  for (const engine::ModelImage& image : model.images)
    if (image.id == name) found = &image;
  if (!found)
    throw util::Error(util::ErrorKind::kNotFound,
                      "no image '" + name + "' in the model (" +
                          std::to_string(model.images.size()) + " images)");
  const engine::CameraIntrinsics& c =
      model.cameras.at(found->camera).intrinsics;
  const double scale = width > 0 ? static_cast<double>(width) / c.width : 1;
  engine::PinholeView view;
  view.K << c.fx * scale, 0, c.cx * scale, 0, c.fy * scale, c.cy * scale, 0, 0,
      1;
  const auto& q = found->qvec;
  view.R = Eigen::Quaterniond(q[0], q[1], q[2], q[3]).toRotationMatrix();
  view.t = Eigen::Vector3d(found->tvec[0], found->tvec[1], found->tvec[2]);
  view.size = cv::Size(static_cast<int>(std::lround(c.width * scale)),
                       static_cast<int>(std::lround(c.height * scale)));
  return view;
}

int run_render(const RenderArgs& a) {
  const fs::path path(a.model);
  if (!fs::exists(path)) throw bad(a.model + ": no such file or folder");
  if (a.view.empty() == !a.orbit)
    throw bad("give exactly one of --view IMAGE and --orbit");
  std::string extension = fs::path(a.output).extension().string();
  for (char& c : extension) c = static_cast<char>(std::tolower(c));
  if (extension != ".png" && extension != ".jpg" && extension != ".jpeg")
    throw bad(a.output + ": the output must be a .png or .jpg file");
  const std::optional<engine::Model> model = colmap_model(path);
  const std::vector<engine::ColoredPoint> points = model_points(path, model);
  if (points.empty()) throw bad(a.model + ": no points to draw");
  engine::PinholeView view;
  if (!a.view.empty()) {
    if (!model)
      throw bad(a.model +
                ": --view needs a model with cameras (a folder written by "
                "`arscout reconstruct`, or a COLMAP text model)");
    view = camera_view(*model, a.view, a.width);
  } else {
    view = engine::orbit_view(
        points, a.azimuth, a.elevation,
        cv::Size(a.width > 0 ? a.width : 1280, a.height > 0 ? a.height : 960));
  }
  const engine::PointRendering out = engine::render_points(
      points, view.K, view.R, view.t, view.size, a.radius);
  if (!cv::imwrite(a.output, out.bgr))
    throw util::Error(util::ErrorKind::kUnavailable,
                      a.output + ": cannot write");
  std::cout << "drew " << points.size() << " points, "
            << cv::countNonZero(out.depth > 0) << " of " << view.size.area()
            << " pixels covered, " << view.size.width << "x" << view.size.height
            << " -> " << a.output << std::endl;
  return kExitOk;
}

void add_render_command(CLI::App& app) {
  static RenderArgs args;
  CLI::App* cmd = app.add_subcommand(
      "render",
      "draw a model's point cloud offline (CPU, z-buffer) from one of its "
      "cameras (--view) or from outside (--orbit), as PNG or JPEG");
  cmd->add_option("--model", args.model,
                  "a folder written by `arscout reconstruct` (dense.ply, else "
                  "sparse.ply, cameras from sparse/), a COLMAP text model "
                  "folder, or a PLY file (--orbit only)")
      ->required();
  cmd->add_option("--view", args.view,
                  "draw from this image's camera, e.g. 0005.jpg");
  cmd->add_flag("--orbit", args.orbit,
                "draw the whole cloud from outside, looking at its median");
  cmd->add_option("--azimuth", args.azimuth,
                  "orbit: degrees clockwise from +y (north in ENU)")
      ->capture_default_str();
  cmd->add_option("--elevation", args.elevation,
                  "orbit: degrees above the x-y plane")
      ->capture_default_str()
      ->check(CLI::Range(-89.0, 89.0));
  cmd->add_option("--width", args.width,
                  "image width (orbit default 1280; a view: its camera's "
                  "width, scaled)")
      ->check(CLI::Range(16, 16384));
  cmd->add_option("--height", args.height, "orbit: image height (default 960)")
      ->check(CLI::Range(16, 16384));
  cmd->add_option("--radius", args.radius,
                  "each point covers (2 R + 1)^2 pixels")
      ->capture_default_str()
      ->check(CLI::Range(0, 20));
  cmd->add_option("-o,--output", args.output, "image to write (.png, .jpg)")
      ->required();
  cmd->callback([] { run_command([] { return run_render(args); }); });
}

const CommandRegistration render_command_registration(53, add_render_command);

}  // namespace
}  // namespace arscout::cli
