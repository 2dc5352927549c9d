// `arscout render-site`: photos of a synthetic site (synthetic_site.h) as a
// scout would bring them, in the layout of ../shared/data/strecha/*, so that
// the main job and scale tests run without ../shared/data.
//
// --scene street: the street scene's converging cameras, JPEGs, a gps.csv
// with each camera's exact position and a K.txt (the main job's stand-in).
// --scene block: the block scene's loop walk, plus what the Strecha folders
// carry for evaluation: a gps.csv from a simulated receiver (the true centre
// plus Gaussian noise), gps_truth.csv without the noise, and
// gt_dense_cameras/*.camera with the exact poses.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <string>

#include <opencv2/imgcodecs.hpp>

#include "arscout/engine/geo.h"
#include "arscout/engine/synthetic_site.h"
#include "cli_support.h"
#include "command_registry.h"
#include "commands.h"

namespace arscout::cli {
namespace {

namespace fs = std::filesystem;
namespace syn = engine::synthetic;

struct RenderSiteArgs {
  std::string out;
  std::string scene = "street";
  int views = 0;  // 0: the scene's default
  int width = 1024;
  int height = 768;
  uint32_t seed = 1;
  bool leave_unseen = false;
  double lat = 47.05870, lon = 15.46010, alt = 360;  // a street in Graz
};

constexpr int kStreetViews = 10;
constexpr int kBlockViews = 60;
// The simulated receiver: 1-sigma error per horizontal axis and vertically,
// the 2-5 m of a WAAS receiver (as in the Strecha folders' gps.csv).
constexpr double kGpsHorizontalSigma = 1.5;
constexpr double kGpsVerticalSigma = 3.0;

std::string image_name(int index) {
  char name[32];
  std::snprintf(name, sizeof name, "%04d.jpg", index);
  return name;
}

void write_jpeg(const fs::path& path, const cv::Mat& bgr) {
  if (!cv::imwrite(path.string(), bgr, {cv::IMWRITE_JPEG_QUALITY, 95}))
    throw std::runtime_error("cannot write " + path.string());
}

void write_k(const fs::path& path, const Eigen::Matrix3d& K) {
  std::ofstream k(path);
  k << std::setprecision(12);
  for (int row = 0; row < 3; ++row)
    k << K(row, 0) << " " << K(row, 1) << " " << K(row, 2) << "\n";
  if (!k) throw std::runtime_error("cannot write " + path.string());
}

std::ofstream open_gps_csv(const fs::path& path) {
  std::ofstream gps(path);
  gps << "image,latitude,longitude,altitude,horizontal_accuracy_m,"
         "vertical_accuracy_m\n"
      << std::fixed;
  return gps;
}

void write_gps_row(std::ofstream& gps, const std::string& name,
                   const engine::Geodetic& g, const char* accuracies) {
  gps << name << std::setprecision(9) << "," << g.lat << "," << g.lon
      << std::setprecision(3) << "," << g.alt << "," << accuracies << "\n";
}

// Unchanged since the street was the only scene: the main job and its tests
// compare against this output.
int run_street(const RenderSiteArgs& a, int views) {
  const fs::path images = fs::path(a.out) / "images";
  fs::create_directories(images);
  const cv::Size size(a.width, a.height);
  const double focal = 0.875 * a.width;  // about a 60 degree field of view
  const syn::Site site = syn::street_site(7);
  const engine::EnuFrame frame({a.lat, a.lon, a.alt});
  std::ofstream gps = open_gps_csv(fs::path(a.out) / "gps.csv");
  int index = 0;
  for (const syn::PinholeView& view : syn::street_cameras(views, size, focal)) {
    const std::string name = image_name(index++);
    write_jpeg(images / name, syn::render(site, view).bgr);
    const Eigen::Vector3d c = view.centre();
    write_gps_row(gps, name, frame.to_geodetic({c.x(), c.y(), c.z()}),
                  "1.00,2.00");
    std::cout << "rendered " << (images / name).string() << std::endl;
  }
  write_k(images / "K.txt", syn::street_cameras(1, size, focal)[0].K);
  if (!gps) throw std::runtime_error("cannot write into " + a.out);
  std::cout << views << " photos of the synthetic street in " << a.out
            << " (gps.csv, images/K.txt)" << std::endl;
  return kExitOk;
}

// unseen_facade.json: the wall --leave-unseen left out, its bottom edge's
// ends on WGS84 and the bearing it faces, for the coverage test to compare
// the suggestions with.
void write_unseen_wall(const fs::path& path, const syn::UnseenWall& wall,
                       const engine::EnuFrame& frame, int left_out) {
  const auto point = [&](const Eigen::Vector3d& p) {
    const engine::Geodetic g = frame.to_geodetic({p.x(), p.y(), p.z()});
    std::ostringstream text;
    text << std::setprecision(10) << "{\"lat\": " << g.lat
         << ", \"lon\": " << g.lon << "}";
    return text.str();
  };
  std::ofstream out(path);
  out << "{\"from\": " << point(wall.from) << ", \"to\": " << point(wall.to)
      << ", \"facing_deg\": " << std::setprecision(6) << wall.facing_deg
      << ", \"photos_left_out\": " << left_out << "}\n";
  if (!out) throw std::runtime_error("cannot write " + path.string());
}

int run_block(const RenderSiteArgs& a, int views) {
  const fs::path out(a.out);
  const fs::path images = out / "images", cameras = out / "gt_dense_cameras";
  fs::create_directories(images);
  fs::create_directories(cameras);
  const cv::Size size(a.width, a.height);
  const syn::BlockScene scene =
      syn::block_scene(a.seed, views, size, 0.875 * a.width);
  const engine::EnuFrame frame({a.lat, a.lon, a.alt});
  std::ofstream gps = open_gps_csv(out / "gps.csv");
  std::ofstream truth = open_gps_csv(out / "gps_truth.csv");
  // Its own stream, so the noise does not shift with the scene's draws.
  syn::SplitMix64 noise(a.seed ^ 0x6a09e667f3bcc909ull);
  std::vector<bool> left_out(scene.views.size(), false);
  if (a.leave_unseen) {
    const syn::UnseenWall wall = syn::unseen_inner_wall(scene);
    left_out = wall.seen_by;
    write_unseen_wall(
        out / "unseen_facade.json", wall, frame,
        static_cast<int>(std::count(left_out.begin(), left_out.end(), true)));
  }
  double render_seconds = 0;
  for (size_t i = 0; i < scene.views.size(); ++i) {
    const syn::PinholeView& view = scene.views[i];
    const std::string name = image_name(static_cast<int>(i));
    // The GPS noise is drawn for every view, so the others' fixes are the
    // same with and without --leave-unseen.
    const double east = kGpsHorizontalSigma * noise.gaussian();
    const double north = kGpsHorizontalSigma * noise.gaussian();
    const double up = kGpsVerticalSigma * noise.gaussian();
    if (left_out[i]) continue;
    const auto start = std::chrono::steady_clock::now();
    const syn::Rendering rendering = syn::render(scene.site, view);
    render_seconds +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
            .count();
    write_jpeg(images / name, rendering.bgr);
    std::ofstream camera(cameras / (name + ".camera"));
    camera << syn::strecha_camera(view);
    if (!camera) throw std::runtime_error("cannot write a camera of " + name);
    const Eigen::Vector3d c = view.centre();
    write_gps_row(truth, name, frame.to_geodetic({c.x(), c.y(), c.z()}),
                  "0.00,0.00");
    write_gps_row(gps, name,
                  frame.to_geodetic({c.x() + east, c.y() + north, c.z() + up}),
                  "1.50,3.00");
    std::cout << "rendered " << (images / name).string() << std::endl;
  }
  write_k(images / "K.txt", scene.views.front().K);
  if (!gps || !truth) throw std::runtime_error("cannot write into " + a.out);
  const long rendered =
      views - std::count(left_out.begin(), left_out.end(), true);
  std::cout << rendered << " photos of the synthetic block (seed " << a.seed
            << ") in " << a.out
            << " (gps.csv, gps_truth.csv, gt_dense_cameras/, images/K.txt"
            << (a.leave_unseen ? ", unseen_facade.json" : "") << "), "
            << std::fixed << std::setprecision(2)
            << render_seconds / std::max(1L, rendered)
            << " s per photo to render" << std::endl;
  return kExitOk;
}

int run_render_site(const RenderSiteArgs& a) {
  if (a.scene == "block")
    return run_block(a, a.views > 0 ? a.views : kBlockViews);
  return run_street(a, a.views > 0 ? a.views : kStreetViews);
}

void add_render_site_command(CLI::App& app) {
  static RenderSiteArgs args;
  CLI::App* cmd = app.add_subcommand(
      "render-site",
      "render photos of a synthetic site with GPS and K.txt (the main job's "
      "and the scale tests' stand-in for ../shared/data)");
  // A raw string keeps the help text's own layout.
  cmd->footer(R"(Scenes:
  street  a facade, its street and a box, seen by converging cameras spread
          over 4 m; gps.csv holds the exact positions.
  block   a scout's loop walk round a city block, through a courtyard, with
          bursts of photos turning on the spot. The layout grows with --views
          (about 0.85 m of walk per photo; use 60 or more) and follows --seed.
          Also writes gps.csv from a simulated receiver (1.5 m of noise per
          horizontal axis, 3 m vertically), gps_truth.csv without the noise,
          and gt_dense_cameras/*.camera (Strecha layout: the exact poses in
          the east-north-up frame at --lat/--lon/--alt). With
          --leave-unseen, the photos that see one wall are not written and
          unseen_facade.json names that wall.)");
  cmd->add_option("--out", args.out, "folder to write")->required();
  cmd->add_option("--scene", args.scene, "street or block")
      ->capture_default_str()
      ->check(CLI::IsMember({"street", "block"}));
  cmd->add_option("--views", args.views,
                  "photos (default 10 for street, 60 for block)")
      ->check(CLI::Range(3, 1000));
  cmd->add_option("--seed", args.seed,
                  "block only: its layout, walk, textures and GPS noise")
      ->capture_default_str();
  cmd->add_flag("--leave-unseen", args.leave_unseen,
                "block only, 60-80 views: leave out the stretch of the walk "
                "that looks at one wall of the building it goes round, so "
                "that facade is never photographed, and name it in "
                "unseen_facade.json");
  cmd->add_option("--width", args.width, "photo width, px")
      ->capture_default_str()
      ->check(CLI::Range(64, 8192));
  cmd->add_option("--height", args.height, "photo height, px")
      ->capture_default_str()
      ->check(CLI::Range(64, 8192));
  cmd->add_option("--lat", args.lat, "latitude of the site's origin")
      ->capture_default_str();
  cmd->add_option("--lon", args.lon, "longitude of the site's origin")
      ->capture_default_str();
  cmd->add_option("--alt", args.alt, "ellipsoidal height of the origin, m")
      ->capture_default_str();
  cmd->callback([] { run_command([] { return run_render_site(args); }); });
}

const CommandRegistration render_site_command_registration(
    27, add_render_site_command);

}  // namespace
}  // namespace arscout::cli
