// model_eval: prints how far a COLMAP text model is from ground truth, for
// people and for the reconstruction tests (--json). Exit 0 on success, 2 on
// bad usage or input that cannot be read or compared.
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <optional>
#include <set>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "model_eval.h"

namespace fs = std::filesystem;
// Ordered, so the output reads model, poses, geo as they are added.
using json = nlohmann::ordered_json;
namespace ev = arscout::eval;
using Poses = std::map<std::string, ev::Pose>;

namespace {

struct Options {
  std::string model;
  std::string strecha_gt;
  std::string middlebury_par;
  std::string geo_csv;
  std::string geo_truth;
  bool as_json = false;
  bool observation_fit = false;
};

bool has_truth(const Options& opt) {
  return !opt.strecha_gt.empty() || !opt.middlebury_par.empty();
}

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

Poses read_truth(const Options& opt) {
  return !opt.strecha_gt.empty()
             ? ev::read_strecha_ground_truth(strecha_camera_dir(opt.strecha_gt))
             : ev::read_middlebury_par(opt.middlebury_par);
}

json compare_poses(const Poses& estimated, const Poses& truth,
                   const Options& opt) {
  const bool strecha = !opt.strecha_gt.empty();
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

json fit_figures(const ev::ObservationFit& fit) {
  return {
      {"observations", fit.observations},       {"points", fit.points},
      {"skipped_points", fit.skipped_points},   {"median_px", fit.median_px},
      {"mean_clipped_px", fit.mean_clipped_px}, {"p90_px", fit.p90_px},
      {"image_median_px", fit.image_median_px}};
}

// The model's tracks re-triangulated with its own poses and, when given,
// with the true ones: if the estimate explains the keypoints better than the
// truth does, what pose error remains is set by the keypoints or by the
// ground truth, not by the optimiser.
json observation_fit(const std::string& dir, const Poses& estimated,
                     const Poses& truth) {
  const auto cameras =
      ev::read_colmap_cameras_txt((fs::path(dir) / "cameras.txt").string());
  const auto tracks =
      ev::read_colmap_tracks((fs::path(dir) / "images.txt").string());
  // The true poses carry no camera ids; the images are the model's.
  std::map<std::string, int> camera_ids;
  for (const auto& [name, pose] : estimated) camera_ids[name] = pose.camera_id;
  json out = {{"estimated", fit_figures(ev::fit_observations(
                                estimated, cameras, camera_ids, tracks))}};
  if (!truth.empty()) {
    out["ground_truth"] =
        fit_figures(ev::fit_observations(truth, cameras, camera_ids, tracks));
  }
  return out;
}

json evaluate(const Options& opt) {
  json out = json::object();
  Poses estimated, truth;
  if (!opt.model.empty()) {
    const auto images_txt = (fs::path(opt.model) / "images.txt").string();
    estimated = ev::read_colmap_images_txt(images_txt);
    out["model"] = summarise_model(opt.model, estimated);
    if (has_truth(opt)) {
      truth = read_truth(opt);
      out["poses"] = compare_poses(estimated, truth, opt);
    }
  }
  if (!opt.geo_csv.empty()) out["geo"] = compare_geo(opt);
  if (opt.observation_fit) {
    out["observation_fit"] = observation_fit(opt.model, estimated, truth);
  }
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

// Each image's median residual, one column per set of poses.
void print_image_medians(const json& fit) {
  std::set<std::string> names;
  for (const auto& [poses, figures] : fit.items()) {
    for (const auto& [name, m] : figures.at("image_median_px").items()) {
      names.insert(name);
    }
  }
  std::cout << "  " << pad("image median_px", 18);
  for (const auto& [poses, figures] : fit.items()) std::cout << pad(poses, 17);
  std::cout << "\n";
  for (const auto& name : names) {
    std::cout << "    " << pad(name, 16);
    for (const auto& [poses, figures] : fit.items()) {
      const json& medians = figures.at("image_median_px");
      std::cout << pad(
          medians.contains(name) ? format_value(medians.at(name)) : "-", 17);
    }
    std::cout << "\n";
  }
}

// A row of figures per set of poses, then the per-image medians.
void print_observation_fit(const json& fit) {
  static constexpr const char* kFigures[] = {"observations",    "points",
                                             "skipped_points",  "median_px",
                                             "mean_clipped_px", "p90_px"};
  std::cout << "observation_fit\n  " << pad("poses", 18);
  for (const char* figure : kFigures) std::cout << pad(figure, 17);
  std::cout << "\n";
  for (const auto& [poses, figures] : fit.items()) {
    std::cout << "  " << pad(poses, 18);
    for (const char* figure : kFigures) {
      std::cout << pad(format_value(figures.at(figure)), 17);
    }
    std::cout << "\n";
  }
  print_image_medians(fit);
}

// One block per section: "key  value" rows, then per-camera errors; the
// observation fit is a table of its own.
void print_table(const json& result) {
  for (const auto& [section, fields] : result.items()) {
    if (section == "observation_fit") {
      print_observation_fit(fields);
      continue;
    }
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
  app.add_flag("--observation-fit", opt.observation_fit,
               "re-triangulate the model's tracks with its poses (and the "
               "true ones) and report the reprojection residuals");
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
  if (opt.model.empty() && opt.observation_fit) {
    return "--observation-fit needs --model";
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
