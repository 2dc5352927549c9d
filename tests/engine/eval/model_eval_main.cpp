// model_eval: prints how far a COLMAP text model is from ground truth, for
// people and for the reconstruction tests (--json). Exit 0 on success, 2 on
// bad usage or input that cannot be read or compared.
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <optional>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "model_eval.h"

namespace fs = std::filesystem;
// Ordered, so the output reads model, poses, geo as they are added.
using json = nlohmann::ordered_json;
namespace ev = arscout::eval;

namespace {

struct Options {
  std::string model;
  std::string strecha_gt;
  std::string middlebury_par;
  std::string geo_csv;
  std::string geo_truth;
  bool as_json = false;
};

// What the model folder holds; cameras.txt and points3D.txt are optional so
// that a bare images.txt (e.g. ground truth rewritten) can be evaluated.
json summarise_model(const std::string& dir,
                     const std::map<std::string, ev::Pose>& images) {
  json out = {{"path", dir}, {"images", images.size()}};
  if (fs::exists(fs::path(dir) / "cameras.txt")) {
    out["cameras"] =
        ev::read_colmap_cameras_txt((fs::path(dir) / "cameras.txt").string())
            .size();
  }
  if (fs::exists(fs::path(dir) / "points3D.txt")) {
    const auto points =
        ev::read_colmap_points3d_txt((fs::path(dir) / "points3D.txt").string());
    double track = 0, error = 0;
    for (const auto& p : points) {
      track += p.track_length;
      error += p.error;
    }
    const double n = static_cast<double>(points.size());
    out["points"] = points.size();
    out["mean_track_length"] = points.empty() ? 0.0 : track / n;
    out["mean_reprojection_error_px"] = points.empty() ? 0.0 : error / n;
  }
  return out;
}

// Accepts either the gt_dense_cameras folder or the scene folder above it.
std::string strecha_camera_dir(const std::string& dir) {
  const fs::path nested = fs::path(dir) / "gt_dense_cameras";
  return fs::is_directory(nested) ? nested.string() : dir;
}

json compare_poses(const std::map<std::string, ev::Pose>& estimated,
                   const Options& opt) {
  const bool strecha = !opt.strecha_gt.empty();
  const auto truth =
      strecha
          ? ev::read_strecha_ground_truth(strecha_camera_dir(opt.strecha_gt))
          : ev::read_middlebury_par(opt.middlebury_par);
  const ev::PoseComparison c = ev::compare_to_ground_truth(estimated, truth);
  json cameras = json::array();
  for (const auto& e : c.cameras) {
    cameras.push_back({{"name", e.name},
                       {"centre_error", e.centre_error},
                       {"along_axis_error", e.along_axis_error},
                       {"across_axis_error", e.across_axis_error},
                       {"rotation_error_deg", e.rotation_error_deg}});
  }
  return {{"truth", strecha ? "strecha" : "middlebury"},
          {"matched", c.matched},
          {"truth_images", c.truth_count},
          {"median_centre_error", c.median_centre_error},
          {"max_centre_error", c.max_centre_error},
          {"median_rotation_error_deg", c.median_rotation_error_deg},
          {"max_rotation_error_deg", c.max_rotation_error_deg},
          {"scene_scale", c.scene_scale},
          {"alignment_scale", c.alignment.scale},
          {"per_camera", cameras}};
}

json compare_geo(const Options& opt) {
  int matched = 0;
  const double d = ev::median_geo_distance(
      ev::read_geo_csv(opt.geo_csv), ev::read_geo_csv(opt.geo_truth), &matched);
  return {{"matched", matched}, {"median_distance_m", d}};
}

json evaluate(const Options& opt) {
  json out = json::object();
  if (!opt.model.empty()) {
    const auto images_txt = (fs::path(opt.model) / "images.txt").string();
    const auto estimated = ev::read_colmap_images_txt(images_txt);
    out["model"] = summarise_model(opt.model, estimated);
    if (!opt.strecha_gt.empty() || !opt.middlebury_par.empty()) {
      out["poses"] = compare_poses(estimated, opt);
    }
  }
  if (!opt.geo_csv.empty()) out["geo"] = compare_geo(opt);
  return out;
}

std::string format_value(const json& value) {
  if (value.is_string()) return value.get<std::string>();
  if (!value.is_number_float()) return value.dump();
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", value.get<double>());
  return buf;
}

std::string pad(const std::string& s, std::size_t width) {
  return s.size() >= width ? s + " " : s + std::string(width - s.size(), ' ');
}

void print_cameras(const json& cameras) {
  for (const auto& cam : cameras) {
    std::cout << "    " << pad(cam["name"].get<std::string>(), 20) << "centre "
              << pad(format_value(cam["centre_error"]), 12) << "(along "
              << pad(format_value(cam["along_axis_error"]), 12) << "across "
              << pad(format_value(cam["across_axis_error"]), 12)
              << ") rotation " << format_value(cam["rotation_error_deg"])
              << " deg\n";
  }
}

// One block per section: "key  value" rows, then per-camera errors.
void print_table(const json& result) {
  for (const auto& [section, fields] : result.items()) {
    std::cout << section << "\n";
    for (const auto& [key, value] : fields.items()) {
      if (!value.is_array()) {
        std::cout << "  " << pad(key, 28) << format_value(value) << "\n";
      }
    }
    if (fields.contains("per_camera")) print_cameras(fields["per_camera"]);
  }
}

void add_options(CLI::App& app, Options& opt) {
  app.add_option("--model", opt.model,
                 "COLMAP text model folder (images.txt, cameras.txt, "
                 "points3D.txt)")
      ->check(CLI::ExistingDirectory);
  auto* strecha =
      app.add_option("--strecha-gt", opt.strecha_gt,
                     "Strecha gt_dense_cameras folder (or the scene folder)")
          ->check(CLI::ExistingDirectory);
  auto* middlebury = app.add_option("--middlebury-par", opt.middlebury_par,
                                    "Middlebury *_par.txt")
                         ->check(CLI::ExistingFile);
  strecha->excludes(middlebury);
  auto* geo = app.add_option("--geo-csv", opt.geo_csv,
                             "geo-registered cameras (cameras_geo.csv)")
                  ->check(CLI::ExistingFile);
  auto* truth = app.add_option("--geo-truth", opt.geo_truth,
                               "true positions (e.g. gps_truth.csv)")
                    ->check(CLI::ExistingFile);
  geo->needs(truth);
  truth->needs(geo);
  app.add_flag("--json", opt.as_json, "print one JSON object");
}

// Cross-option rules CLI11 cannot say directly.
std::optional<std::string> usage_problem(const Options& opt) {
  if (opt.model.empty() && opt.geo_csv.empty()) {
    return "give --model and/or --geo-csv";
  }
  if (opt.model.empty() &&
      (!opt.strecha_gt.empty() || !opt.middlebury_par.empty())) {
    return "--strecha-gt and --middlebury-par need --model";
  }
  return std::nullopt;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Compare a COLMAP text model with ground truth"};
  Options opt;
  add_options(app, opt);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // CLI11 has its own exit codes; callers only need "usage error" = 2.
    return app.exit(e) == 0 ? 0 : 2;
  }
  if (auto problem = usage_problem(opt)) {
    std::cerr << "model_eval: " << *problem << "\n" << app.help();
    return 2;
  }
  try {
    const json result = evaluate(opt);
    if (opt.as_json) {
      std::cout << result.dump(2) << "\n";
    } else {
      print_table(result);
    }
  } catch (const std::exception& e) {
    std::cerr << "model_eval: " << e.what() << "\n";
    return 2;
  }
  return 0;
}
