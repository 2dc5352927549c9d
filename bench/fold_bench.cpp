// fold_bench: what folding captures into one increment saves. The first N
// photos of a scene (a rendered block walk: images/*.jpg, images/K.txt,
// gps.csv, gt_dense_cameras/) are added twice in one process, each time
// deterministically on one thread: once a capture per increment, once in
// increments of K captures as the engine service folds a backlog (every
// capture but an increment's last with CaptureInput::more_follow). It
// prints, per run, the global adjustments run inside the increments, the
// adjustment and total seconds, and the cameras' centre error after a
// similarity fit when the scene has its truth. Seconds are CPU-bound and
// single-threaded; compare the two rows of one run, not across machines.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <Eigen/Geometry>

#include "arscout/engine/camera.h"
#include "arscout/engine/image_size.h"
#include "arscout/engine/reconstruction.h"
#include "arscout/metadata/gps.h"
#include "arscout/util/file.h"
#include "model_eval.h"

namespace {

using namespace arscout;

struct Options {
  std::string scene;
  int views = 48;
  int fold = 4;
  int long_side = arscout::engine::ReconstructionOptions{}.long_side;
};

struct RunFigures {
  int registered = 0;
  int global_adjustments = 0;
  double adjustment_s = 0;
  double total_s = 0;
  std::optional<eval::PoseComparison> accuracy;
};

// The scene's first `views` photos as captures, in file-name order.
std::vector<engine::CaptureInput> scene_captures(const Options& o) {
  std::vector<std::string> names;
  for (const auto& entry :
       std::filesystem::directory_iterator(o.scene + "/images")) {
    if (entry.path().extension() == ".jpg")
      names.push_back(entry.path().filename().string());
  }
  std::sort(names.begin(), names.end());
  names.resize(std::min<size_t>(names.size(), o.views));
  if (names.empty()) throw std::runtime_error("no images/*.jpg in " + o.scene);
  const auto fixes = metadata::read_gps_csv(o.scene + "/gps.csv");
  std::vector<engine::CaptureInput> result;
  for (const std::string& name : names) {
    engine::CaptureInput c;
    c.id = name;
    c.image_bytes = util::read_file(o.scene + "/images/" + name);
    const auto size = engine::read_image_size(c.image_bytes);
    if (!size) throw std::runtime_error(name + ": not a JPEG");
    c.camera = engine::read_k_matrix(o.scene + "/images/K.txt", size->width,
                                     size->height);
    c.camera_id = "k";
    c.scout = "scout";
    const auto fix = fixes.find(name);
    if (fix != fixes.end()) {
      engine::GeoFix g;
      g.lat = fix->second.lat;
      g.lon = fix->second.lon;
      g.alt = fix->second.alt;
      g.h_acc = fix->second.h_acc.value_or(5.0);
      g.v_acc = fix->second.v_acc.value_or(10.0);
      c.gps = g;
    }
    result.push_back(std::move(c));
  }
  return result;
}

// The model's poses against the scene's truth, when it has one.
std::optional<eval::PoseComparison> accuracy(const Options& o,
                                             const engine::Model& model) {
  const std::string truth_dir = o.scene + "/gt_dense_cameras";
  if (!std::filesystem::exists(truth_dir) || model.images.size() < 3)
    return std::nullopt;
  const auto truth = eval::read_strecha_ground_truth(truth_dir);
  std::map<std::string, eval::Pose> estimated, matched_truth;
  for (const engine::ModelImage& image : model.images) {
    const auto& q = image.qvec;
    eval::Pose pose;
    pose.name = image.id;
    pose.R = Eigen::Quaterniond(q[0], q[1], q[2], q[3]).toRotationMatrix();
    pose.t = Eigen::Vector3d(image.tvec[0], image.tvec[1], image.tvec[2]);
    estimated[image.id] = pose;
    matched_truth[image.id] = truth.at(image.id);
  }
  return eval::compare_to_ground_truth(estimated, matched_truth);
}

// Adds the captures in increments of `fold` (1: each on its own).
RunFigures run(const Options& o,
               const std::vector<engine::CaptureInput>& captures, int fold) {
  engine::ReconstructionOptions options;
  options.deterministic = true;
  options.threads = 1;
  options.long_side = o.long_side;
  engine::Reconstruction site(options);
  RunFigures figures;
  for (size_t i = 0; i < captures.size(); ++i) {
    engine::CaptureInput input = captures[i];
    const bool last = (i + 1) % fold == 0 || i + 1 == captures.size();
    input.more_follow = !last;
    const engine::AddResult added = site.add_capture(input);
    figures.global_adjustments += added.global_adjustments;
    figures.adjustment_s += added.timings.bundle_adjustment_s;
    figures.total_s += added.timings.total_s;
    std::fprintf(stderr, "\r  fold %d: %zu / %zu", fold, i + 1,
                 captures.size());
  }
  std::fprintf(stderr, "\n");
  figures.registered = site.registered_count();
  figures.accuracy = accuracy(o, site.model());
  return figures;
}

void print_row(int fold, size_t views, const RunFigures& f) {
  std::printf("| %d | %d / %zu | %d | %.2f | %.2f |", fold, f.registered, views,
              f.global_adjustments, f.adjustment_s, f.total_s);
  if (f.accuracy) {
    std::printf(" %.2f / %.2f |\n", 100 * f.accuracy->median_centre_error,
                100 * f.accuracy->max_centre_error);
  } else {
    std::printf(" - |\n");
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"What folding captures into one increment saves"};
  Options o;
  app.add_option("--scene", o.scene,
                 "images/*.jpg, images/K.txt, gps.csv (render-site's output)")
      ->required();
  app.add_option("--views", o.views, "the first N photos")
      ->capture_default_str()
      ->check(CLI::Range(3, 100000));
  app.add_option("--fold", o.fold, "captures per folded increment")
      ->capture_default_str()
      ->check(CLI::Range(2, 1000));
  app.add_option("--long-side", o.long_side,
                 "working resolution, long side in px (as arscout "
                 "reconstruct's)")
      ->capture_default_str()
      ->check(CLI::Range(100, 10000));
  CLI11_PARSE(app, argc, argv);
  try {
    const auto captures = scene_captures(o);
    const RunFigures alone = run(o, captures, 1);
    const RunFigures folded = run(o, captures, o.fold);
    std::printf(
        "%zu photos of %s, deterministic, one thread\n\n"
        "| captures per increment | registered | global adjustments inline "
        "| adjustment s | total s | centre error median / max cm |\n"
        "|---|---|---|---|---|---|\n",
        captures.size(), o.scene.c_str());
    print_row(1, captures.size(), alone);
    print_row(o.fold, captures.size(), folded);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fold_bench: %s\n", e.what());
    return 1;
  }
  return 0;
}
