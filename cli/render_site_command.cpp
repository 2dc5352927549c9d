// `arscout render-site`: photos of the synthetic street (synthetic_site.h)
// as a scout would bring them: JPEGs, a gps.csv with each camera's exact
// position and a K.txt, in the layout of ../shared/data/strecha/*, so that
// the main job runs without ../shared/data.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>

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
  int views = 10;
  int width = 1024;
  int height = 768;
  double lat = 47.05870, lon = 15.46010, alt = 360;  // a street in Graz
};

int run_render_site(const RenderSiteArgs& a) {
  const fs::path images = fs::path(a.out) / "images";
  fs::create_directories(images);
  const cv::Size size(a.width, a.height);
  const double focal = 0.875 * a.width;  // about a 60 degree field of view
  const syn::Site site = syn::street_site(7);
  const engine::EnuFrame frame({a.lat, a.lon, a.alt});
  std::ofstream gps(fs::path(a.out) / "gps.csv");
  gps << "image,latitude,longitude,altitude,horizontal_accuracy_m,"
         "vertical_accuracy_m\n"
      << std::fixed;
  int index = 0;
  for (const syn::PinholeView& view :
       syn::street_cameras(a.views, size, focal)) {
    char name[32];
    std::snprintf(name, sizeof name, "%04d.jpg", index++);
    const syn::Rendering r = syn::render(site, view);
    if (!cv::imwrite((images / name).string(), r.bgr,
                     {cv::IMWRITE_JPEG_QUALITY, 95}))
      throw std::runtime_error("cannot write " + (images / name).string());
    const Eigen::Vector3d c = view.centre();
    const engine::Geodetic g = frame.to_geodetic({c.x(), c.y(), c.z()});
    gps << name << std::setprecision(9) << "," << g.lat << "," << g.lon
        << std::setprecision(3) << "," << g.alt << ",1.00,2.00\n";
    std::cout << "rendered " << (images / name).string() << std::endl;
  }
  std::ofstream k(images / "K.txt");
  const syn::PinholeView first = syn::street_cameras(1, size, focal)[0];
  k << std::setprecision(12);
  for (int row = 0; row < 3; ++row)
    k << first.K(row, 0) << " " << first.K(row, 1) << " " << first.K(row, 2)
      << "\n";
  if (!gps || !k) throw std::runtime_error("cannot write into " + a.out);
  std::cout << a.views << " photos of the synthetic street in " << a.out
            << " (gps.csv, images/K.txt)" << std::endl;
  return kExitOk;
}

void add_render_site_command(CLI::App& app) {
  static RenderSiteArgs args;
  CLI::App* cmd = app.add_subcommand(
      "render-site",
      "render photos of the synthetic street with gps.csv and K.txt (the "
      "main job's stand-in for ../shared/data)");
  cmd->add_option("--out", args.out, "folder to write")->required();
  cmd->add_option("--views", args.views, "photos")
      ->capture_default_str()
      ->check(CLI::Range(3, 200));
  cmd->add_option("--width", args.width, "photo width, px")
      ->capture_default_str()
      ->check(CLI::Range(64, 8192));
  cmd->add_option("--height", args.height, "photo height, px")
      ->capture_default_str()
      ->check(CLI::Range(64, 8192));
  cmd->add_option("--lat", args.lat, "latitude of the street's origin")
      ->capture_default_str();
  cmd->add_option("--lon", args.lon, "longitude of the street's origin")
      ->capture_default_str();
  cmd->add_option("--alt", args.alt, "ellipsoidal height of the origin, m")
      ->capture_default_str();
  cmd->callback([] { run_command([] { return run_render_site(args); }); });
}

const CommandRegistration registration(27, add_render_site_command);

}  // namespace
}  // namespace arscout::cli
