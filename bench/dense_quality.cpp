// dense_quality: how clean and how complete the dense cloud is, on scenes
// with an exact truth and on real photos.
//
//   dense_quality [--seeds 31,47,53] [--views 120] [--width 1024]
//                 [--height 768] [--real DIR]... [--no-real] [--no-block]
//                 [--dense-long-side 640] [--work /tmp/arscout-dense-quality]
//                 [--arscout PATH] [--reconstruct-args "..."] [--check]
//                 [--measure-only]
//
// Each scene goes through `arscout reconstruct --dense` as a child process
// (its log and outputs in WORK/NAME/). For each seed, a block walk is
// rendered first (`render-site --scene block`, reused while its stamp
// matches); the model's camera centres are fitted to the true ones (7-DoF
// similarity, by the cameras that agree: ev::fit_similarity_robust, their
// count printed) and the cloud is moved with them, then:
//
//   - accuracy: each point's distance to the nearest true surface (the
//     scene's quads, exactly): median and 90th percentile;
//   - completeness at 5 cm: the true surfaces sampled every 5 cm; a sample
//     counts when at least 2 key views (the captures that got a depth map,
//     at their true poses) see it unhidden and resolve it (a pixel of the
//     dense working resolution covers at most 5 cm of it there); the share
//     of those with a point within 5 cm, and a table of it split by how
//     many key views see the sample (2, 3, 4-5, 6-7, 8 or more): where the
//     gaps are.
//
// Every scene (the real ones by default: ../shared/data/opensfm/lund and
// strecha/fountain-P11) also gets the implausible share: points more than
// 40 m from their nearest camera horizontally, more than 30 m above or 6 m
// below it, or sky-coloured (tests/engine/eval/dense_eval.h), and points and
// dense seconds per photo (the dense lines' sweep, filter and fusion
// seconds, summed, over the photos). Then the share of confident points
// (support >= 3: what the viewer shows by default) and their implausible
// share, and the ground covered near the cameras (m2 of 5 cm cells within
// 15 cm of the cameras' usual drop, ev::ground_cover_m2).
//
// Targets (issue 36): block p90 <= 5 cm and completeness >= 80 %; lund
// implausible <= 5 %, fountain-P11 <= 3 %. With --check it exits 1 when a
// scene misses one.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <Eigen/Core>
#include <Eigen/Geometry>

#include "arscout/engine/mesh.h"
#include "arscout/engine/ply.h"
#include "arscout/engine/synthetic_site.h"
#include "arscout/util/file.h"
#include "bench_support.h"
#include "child_process.h"
#include "dense_eval.h"
#include "model_eval.h"
#include "progress_log.h"

namespace {

namespace fs = std::filesystem;
namespace ev = arscout::eval;
namespace syn = arscout::engine::synthetic;
namespace bench = arscout::bench;
using bench::fixed;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// The truth's depth images are rendered this wide (the height in
// proportion): a sample's visibility needs no finer picture.
constexpr int kTruthDepthWidth = 256;

struct Options {
  std::vector<int> seeds = {31, 47, 53};
  int views = 120;
  int width = 1024;
  int height = 768;
  std::vector<std::string> real;
  bool no_real = false;
  bool no_block = false;
  int dense_long_side = 640;
  std::string work = "/tmp/arscout-dense-quality";
  std::string arscout = ARSCOUT_EXE;
  std::string reconstruct_args;
  bool check = false;
  bool measure_only = false;  // measure WORK's outputs of an earlier run
  bool mesh = false;          // also the surface (reconstruct --mesh)
};

struct Row {
  std::string label;
  std::string error;  // why figures are missing, or ""
  bool block = false;
  double max_implausible = kNaN;  // the scene's target, NaN for none
  int photos = 0, registered = 0, depth_maps = 0;
  int fitted_cameras = 0;  // block walks: the cameras the alignment used
  long points = 0;
  double dense_s_per_photo = kNaN, wall_s = kNaN;
  ev::AccuracyFigures accuracy;
  ev::CompletenessFigures completeness;
  ev::PlausibilityFigures plausibility;
  // Of the confident points (support >= kConfidentSupport), what the
  // viewer shows by default.
  double confident_share = kNaN;
  ev::PlausibilityFigures confident_plausibility;
  double ground_m2 = kNaN;  // ev::ground_cover_m2
  // With --mesh: the surface's triangles, its samples against the truth
  // (block walks), and each key view predicted from the others
  // (reconstruct --mesh-check: medians of ZNCC and covered share).
  long mesh_triangles = 0;
  ev::AccuracyFigures mesh_accuracy;
  ev::CompletenessFigures mesh_completeness;
  double holdout_zncc = kNaN, holdout_covered = kNaN;
};

int count_photos(const fs::path& images) {
  int photos = 0;
  for (const auto& entry : fs::directory_iterator(images)) {
    const std::string ext = entry.path().extension().string();
    photos += ext == ".jpg" || ext == ".JPG" || ext == ".jpeg" || ext == ".png";
  }
  return photos;
}

// `arscout reconstruct --dense` on `scene` (its images/, and gps.csv and
// images/K.txt where it has them) into dir/out; false, with row.error set,
// when it fails.
bool reconstruct(const Options& o, const fs::path& scene, const fs::path& dir,
                 Row& row) {
  std::vector<std::string> args = {"reconstruct",
                                   "--images",
                                   (scene / "images").string(),
                                   "--out",
                                   (dir / "out").string(),
                                   "--dense",
                                   "--dense-long-side",
                                   std::to_string(o.dense_long_side)};
  if (fs::exists(scene / "gps.csv"))
    args.insert(args.end(), {"--gps-csv", (scene / "gps.csv").string()});
  if (fs::exists(scene / "images" / "K.txt"))
    args.insert(args.end(),
                {"--camera", (scene / "images" / "K.txt").string()});
  // The held-out check textures the surface again once per key view: a
  // block walk's hundred are left to the truth's figures.
  if (o.mesh) args.push_back("--mesh");
  if (o.mesh && !row.block) args.push_back("--mesh-check");
  std::istringstream extra(o.reconstruct_args);
  for (std::string word; extra >> word;) args.push_back(word);
  if (o.measure_only) {
    if (fs::exists(dir / "out/dense.ply")) return true;
    row.error = "no earlier run's " + (dir / "out/dense.ply").string();
    return false;
  }
  fs::remove_all(dir / "out");
  std::cerr << row.label << ": reconstructing" << std::endl;
  const std::string log = (dir / "reconstruct.log").string();
  const bench::ChildResult r = bench::run_child(o.arscout, args, log);
  row.wall_s = r.wall_s;
  if (bench::exited_ok(r)) return true;
  row.error = "reconstruct failed (see " + log + ")";
  std::cerr << row.error << ":\n" << bench::last_lines(log, 5);
  return false;
}

// What a reconstruct run wrote: the model's poses, the cloud, and the
// captures that got a depth map (from its log).
struct Outputs {
  std::map<std::string, ev::Pose> poses;
  std::vector<ev::CloudPoint> cloud;
  std::vector<std::string> key_views;
  std::vector<Eigen::Vector3d> mesh_samples;  // with --mesh
};

// Points on the surface's triangles, about one per `spacing` squared
// (at least one per triangle; the same points every run).
std::vector<Eigen::Vector3d> sample_mesh(const arscout::engine::TexturedMesh& m,
                                         double spacing) {
  std::vector<Eigen::Vector3d> samples;
  for (std::size_t t = 0; t + 2 < m.indices.size(); t += 3) {
    const Eigen::Vector3d a = m.positions[m.indices[t]].cast<double>();
    const Eigen::Vector3d b = m.positions[m.indices[t + 1]].cast<double>();
    const Eigen::Vector3d c = m.positions[m.indices[t + 2]].cast<double>();
    const double area = 0.5 * (b - a).cross(c - a).norm();
    const int n =
        std::max(1, static_cast<int>(std::lround(area / (spacing * spacing))));
    for (int k = 0; k < n; ++k) {
      // The R2 sequence folded into the triangle.
      double u = std::fmod(0.5 + 0.7548776662 * (k + 1), 1.0);
      double v = std::fmod(0.5 + 0.5698402910 * (k + 1), 1.0);
      if (u + v > 1) u = 1 - u, v = 1 - v;
      samples.push_back(a + u * (b - a) + v * (c - a));
    }
  }
  return samples;
}

// reconstruct --mesh-check's table: the medians of its ZNCC and covered
// share.
void read_mesh_check(const fs::path& csv, Row& row) {
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);  // header
  std::vector<double> zncc, covered;
  while (std::getline(in, line)) {
    std::istringstream fields(line);
    std::string id, z, c;
    if (std::getline(fields, id, ',') && std::getline(fields, z, ',') &&
        std::getline(fields, c, ',')) {
      zncc.push_back(std::stod(z));
      covered.push_back(std::stod(c));
    }
  }
  if (zncc.empty()) throw std::runtime_error("no views in " + csv.string());
  row.holdout_zncc = ev::percentile(zncc, 0.5);
  row.holdout_covered = ev::percentile(covered, 0.5);
}

// Reads the outputs in `dir` and fills the figures every scene gets:
// counts, dense seconds, plausibility.
Outputs measure_common(const fs::path& dir, Row& row) {
  Outputs out;
  const ev::ProgressLog log =
      ev::read_progress_log((dir / "reconstruct.log").string());
  out.key_views = log.depth_map_ids();
  row.depth_maps = static_cast<int>(out.key_views.size());
  row.dense_s_per_photo = log.dense_seconds() / std::max(1, row.photos);
  out.poses =
      ev::read_colmap_images_txt((dir / "out/sparse/images.txt").string());
  row.registered = static_cast<int>(out.poses.size());
  for (const auto& p :
       arscout::engine::read_ply((dir / "out/dense.ply").string()))
    out.cloud.push_back(
        {Eigen::Vector3d(p.x, p.y, p.z), p.r, p.g, p.b, p.support});
  row.points = static_cast<long>(out.cloud.size());
  std::vector<Eigen::Vector3d> centres;
  for (const auto& [name, pose] : out.poses) centres.push_back(pose.centre());
  row.plausibility = ev::measure_plausibility(out.cloud, centres);
  std::vector<ev::CloudPoint> confident;
  for (const ev::CloudPoint& p : out.cloud)
    if (p.support >= arscout::engine::kConfidentSupport) confident.push_back(p);
  row.confident_share = static_cast<double>(confident.size()) /
                        std::max<size_t>(1, out.cloud.size());
  row.confident_plausibility = ev::measure_plausibility(confident, centres);
  row.ground_m2 = ev::ground_cover_m2(out.cloud, centres);
  if (fs::exists(dir / "out/mesh.glb")) {
    const arscout::engine::TexturedMesh mesh = arscout::engine::decode_glb(
        arscout::util::read_file((dir / "out/mesh.glb").string()));
    row.mesh_triangles = static_cast<long>(mesh.triangles());
    out.mesh_samples = sample_mesh(mesh, 0.03);
  }
  if (fs::exists(dir / "out/mesh_check.csv"))
    read_mesh_check(dir / "out/mesh_check.csv", row);
  return out;
}

// The truth's view scaled to `width` pixels across, its exact depth
// rendered.
ev::DepthView truth_depth_view(const syn::Site& site,
                               const syn::PinholeView& view, int width) {
  const double s = static_cast<double>(width) / view.size.width;
  syn::PinholeView small = view;
  small.size = cv::Size(width, static_cast<int>(view.size.height * s));
  small.K.row(0) *= s;
  small.K.row(1) *= s;
  // Pixel centres at integer coordinates: (c + 0.5) s - 0.5.
  small.K(0, 2) = (view.K(0, 2) + 0.5) * s - 0.5;
  small.K(1, 2) = (view.K(1, 2) + 0.5) * s - 0.5;
  const syn::Rendering r = syn::render(site, small, 1);
  ev::DepthView out{small.K,          small.R,           small.t,
                    small.size.width, small.size.height, {}};
  out.depth.assign(r.depth.begin<float>(), r.depth.end<float>());
  return out;
}

std::vector<ev::Parallelogram> surfaces_of(const syn::Site& site) {
  std::vector<ev::Parallelogram> surfaces;
  for (const syn::Quad& q : site.quads)
    surfaces.push_back({q.corner, q.edge_u, q.edge_v});
  return surfaces;
}

// Accuracy and completeness of the block walk's cloud against its quads.
void measure_truth(const Options& o, int seed, const fs::path& dir,
                   const Outputs& out, Row& row) {
  const syn::BlockScene scene =
      syn::block_scene(static_cast<uint32_t>(seed), o.views,
                       cv::Size(o.width, o.height), 0.875 * o.width);
  const auto truth =
      ev::read_strecha_ground_truth((dir / "site/gt_dense_cameras").string());
  // Aligned by the cameras that agree (fit_similarity_robust): a few
  // photos the sparse stage left in a component of their own, placed by
  // their own fixes a metre or two off, would otherwise pull the whole
  // cloud off the truth. Their points still count.
  std::vector<Eigen::Vector3d> from, to;
  for (const auto& [name, pose] : out.poses) {
    auto it = truth.find(name);
    if (it == truth.end()) continue;
    from.push_back(pose.centre());
    to.push_back(it->second.centre());
  }
  const ev::Similarity to_truth =
      ev::fit_similarity_robust(from, to, &row.fitted_cameras);
  std::vector<Eigen::Vector3d> points;
  for (const ev::CloudPoint& p : out.cloud)
    points.push_back(to_truth.apply(p.xyz));
  const auto surfaces = surfaces_of(scene.site);
  row.accuracy = ev::measure_accuracy(points, ev::SurfaceDistance(surfaces));
  std::vector<ev::DepthView> key_views;
  for (const std::string& id : out.key_views) {
    const int index = std::stoi(id);  // "0042.jpg": view 42 of the walk
    if (index >= 0 && index < static_cast<int>(scene.views.size()))
      key_views.push_back(
          truth_depth_view(scene.site, scene.views[index], kTruthDepthWidth));
  }
  ev::CompletenessOptions options;
  options.footprint_focal_px =
      0.875 * o.width * o.dense_long_side / std::max(o.width, o.height);
  row.completeness =
      ev::measure_completeness(surfaces, key_views, points, options);
  if (out.mesh_samples.empty()) return;
  std::vector<Eigen::Vector3d> samples;
  for (const Eigen::Vector3d& p : out.mesh_samples)
    samples.push_back(to_truth.apply(p));
  row.mesh_accuracy =
      ev::measure_accuracy(samples, ev::SurfaceDistance(surfaces));
  row.mesh_completeness =
      ev::measure_completeness(surfaces, key_views, samples, options);
}

Row measure_block(const Options& o, int seed) {
  Row row;
  row.label = "block seed " + std::to_string(seed);
  row.block = true;
  row.photos = o.views;
  const fs::path dir = fs::path(o.work) / ("block" + std::to_string(seed));
  fs::create_directories(dir);
  bench::render_block_walk(o.arscout, {o.views, seed, o.width, o.height},
                           (dir / "site").string(),
                           (dir / "render.log").string(), row.label);
  if (!reconstruct(o, dir / "site", dir, row)) return row;
  try {
    measure_truth(o, seed, dir, measure_common(dir, row), row);
  } catch (const std::exception& e) {
    row.error = e.what();
  }
  return row;
}

Row measure_real(const Options& o, const fs::path& scene) {
  Row row;
  row.label = scene.filename().string();
  if (row.label == "lund") row.max_implausible = 0.05;
  if (row.label == "fountain-P11") row.max_implausible = 0.03;
  if (!fs::is_directory(scene / "images")) {
    row.error = "no " + (scene / "images").string();
    return row;
  }
  row.photos = count_photos(scene / "images");
  const fs::path dir = fs::path(o.work) / row.label;
  fs::create_directories(dir);
  if (!reconstruct(o, scene, dir, row)) return row;
  try {
    measure_common(dir, row);
  } catch (const std::exception& e) {
    row.error = e.what();
  }
  return row;
}

std::string percent(double share) { return fixed(100 * share, 1) + " %"; }

void print_rows(const std::vector<Row>& rows) {
  std::cout << "| scene | registered | cameras fitted | depth maps | "
               "points | points / photo "
               "| dense s / photo | accuracy median cm | p90 cm | within 5 cm "
               "| completeness 5 cm | implausible | far | above | below | "
               "sky | confident | implausible, confident | ground m2 |\n"
               "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
               "---|---|---|---|\n";
  for (const Row& r : rows) {
    const auto& a = r.accuracy;
    const auto& p = r.plausibility;
    std::cout << "| " << r.label << " | " << r.registered << "/" << r.photos
              << " | " << (r.block ? std::to_string(r.fitted_cameras) : "-")
              << " | " << r.depth_maps << " | " << r.points << " | "
              << fixed(static_cast<double>(r.points) / std::max(1, r.photos), 0)
              << " | " << fixed(r.dense_s_per_photo, 2) << " | "
              << (r.block ? fixed(100 * a.median_m, 2) : "-") << " | "
              << (r.block ? fixed(100 * a.p90_m, 2) : "-") << " | "
              << (r.block ? percent(a.within_share) : "-") << " | "
              << (r.block ? percent(r.completeness.share) : "-") << " | "
              << percent(p.implausible_share) << " | " << percent(p.far_share)
              << " | " << percent(p.above_share) << " | "
              << percent(p.below_share) << " | " << percent(p.sky_share)
              << " | " << percent(r.confident_share) << " | "
              << percent(r.confident_plausibility.implausible_share) << " | "
              << fixed(r.ground_m2, 1) << " |\n";
  }
  for (const Row& r : rows)
    if (!r.error.empty()) std::cout << r.label << ": " << r.error << "\n";
  std::cout << std::endl;
}

// With --mesh: the surface's figures (docs/mesh.md).
void print_mesh_rows(const std::vector<Row>& rows) {
  std::cout << "| scene | triangles | mesh accuracy median cm | p90 cm | "
               "within 5 cm | completeness 5 cm | held-out ZNCC (median) | "
               "covered (median) |\n|---|---|---|---|---|---|---|---|\n";
  for (const Row& r : rows) {
    const auto& a = r.mesh_accuracy;
    const bool truth = r.block && a.points > 0;
    std::cout << "| " << r.label << " | " << r.mesh_triangles << " | "
              << (truth ? fixed(100 * a.median_m, 2) : "-") << " | "
              << (truth ? fixed(100 * a.p90_m, 2) : "-") << " | "
              << (truth ? percent(a.within_share) : "-") << " | "
              << (truth ? percent(r.mesh_completeness.share) : "-") << " | "
              << fixed(r.holdout_zncc, 3) << " | " << percent(r.holdout_covered)
              << " |\n";
  }
  std::cout << std::endl;
}

// Where the gaps are: the block walks' seen surface and its completeness
// split by how many key views see it (ev::CompletenessFigures).
void print_completeness_by_views(const std::vector<Row>& rows) {
  struct Range {
    const char* label;
    int from, to;
  };
  const Range ranges[] = {{"2", 2, 2},
                          {"3", 3, 3},
                          {"4-5", 4, 5},
                          {"6-7", 6, 7},
                          {"8+", ev::kMostViewsCounted, ev::kMostViewsCounted}};
  std::vector<const Row*> measured;
  for (const Row& r : rows)
    if (r.block && r.completeness.seen > 0) measured.push_back(&r);
  if (measured.empty()) return;
  std::cout << "| scene | key views seeing the surface |";
  for (const Range& range : ranges) std::cout << " " << range.label << " |";
  std::cout << "\n|---|---|---|---|---|---|---|\n";
  auto sum = [](const auto& counts, const Range& range) {
    int64_t total = 0;
    for (int k = range.from; k <= range.to; ++k) total += counts[k];
    return static_cast<double>(total);
  };
  auto line = [&](const Row& r, const char* what, auto share_of) {
    std::cout << "| " << r.label << " | " << what << " |";
    for (const Range& range : ranges)
      std::cout << " " << percent(share_of(range)) << " |";
    std::cout << "\n";
  };
  // Per range, the share of its seen samples that `f` covers.
  auto covered = [&](const ev::CompletenessFigures& f) {
    return [&](const Range& range) {
      const double seen = sum(f.seen_by_views, range);
      return seen > 0 ? sum(f.covered_by_views, range) / seen : 0.0;
    };
  };
  for (const Row* r : measured) {
    const auto& cloud = r->completeness;
    line(*r, "share of the seen surface", [&](const Range& range) {
      return sum(cloud.seen_by_views, range) / cloud.seen;
    });
    line(*r, "cloud completeness", covered(cloud));
    if (r->mesh_completeness.seen > 0)
      line(*r, "mesh completeness", covered(r->mesh_completeness));
  }
  std::cout << std::endl;
}

// The PASS/FAIL lines; true when every scene meets its targets.
bool print_targets(const std::vector<Row>& rows) {
  bool all_met = true;
  auto verdict = [&](const Row& r, const std::string& what, bool met) {
    std::cout << r.label << ": " << what << (met ? " PASS" : " FAIL") << "\n";
    all_met = all_met && met;
  };
  for (const Row& r : rows) {
    if (!r.error.empty()) {
      verdict(r, "ran", false);
      continue;
    }
    if (r.block) {
      verdict(r, "accuracy p90 <= 5 cm", r.accuracy.p90_m <= 0.05);
      verdict(r, "completeness >= 80 % at 5 cm", r.completeness.share >= 0.8);
    }
    if (r.block && r.mesh_triangles > 0) {
      verdict(r, "mesh accuracy p90 <= 5 cm", r.mesh_accuracy.p90_m <= 0.05);
      verdict(r, "mesh completeness >= 85 % at 5 cm",
              r.mesh_completeness.share >= 0.85);
    }
    if (r.label == "fountain-P11" && !std::isnan(r.holdout_zncc))
      verdict(r, "held-out ZNCC >= 0.6 (median)", r.holdout_zncc >= 0.6);
    if (!std::isnan(r.max_implausible))
      verdict(r, "implausible <= " + percent(r.max_implausible),
              r.plausibility.implausible_share <= r.max_implausible);
  }
  std::cout << std::endl;
  return all_met;
}

void add_options(CLI::App& app, Options& o) {
  app.add_option("--seeds", o.seeds, "block seeds, comma-separated")
      ->delimiter(',');
  app.add_option("--views", o.views, "photos in each block walk")
      ->check(CLI::Range(3, 1000));
  app.add_option("--width", o.width, "block photo width, px");
  app.add_option("--height", o.height, "block photo height, px");
  app.add_option("--real", o.real,
                 "a real scene folder (with images/); repeatable; default "
                 "../shared/data/opensfm/lund and strecha/fountain-P11");
  app.add_flag("--no-real", o.no_real, "block walks only");
  app.add_flag("--no-block", o.no_block, "real scenes only");
  app.add_option("--dense-long-side", o.dense_long_side,
                 "the dense working resolution, passed to reconstruct");
  app.add_option("--work", o.work, "work folder: WORK/NAME/{site,out,*.log}");
  app.add_option("--arscout", o.arscout, "the arscout executable");
  app.add_option("--reconstruct-args", o.reconstruct_args,
                 "extra arguments for arscout reconstruct, space-separated");
  app.add_flag("--check", o.check, "exit 1 when a scene misses a target");
  app.add_flag("--mesh", o.mesh,
               "also the surface: reconstruct --mesh, the mesh's samples "
               "against the truth (block walks) and, with --mesh-check, "
               "each key view predicted from the others (real scenes)");
  app.add_flag("--measure-only", o.measure_only,
               "measure the outputs an earlier run left in --work (its "
               "reconstruct.log and out/), reconstructing nothing");
}

std::vector<std::string> default_real_scenes() {
  const fs::path data = fs::path(ARSCOUT_SOURCE_DIR) / "../shared/data";
  std::vector<std::string> scenes;
  for (const char* name : {"opensfm/lund", "strecha/fountain-P11"})
    if (fs::is_directory(data / name))
      scenes.push_back((data / name).lexically_normal().string());
    else
      std::cerr << "dense_quality: " << (data / name).string()
                << " is absent: skipped" << std::endl;
  return scenes;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "dense_quality: the dense cloud against exact surfaces, and "
      "its implausible points on real photos"};
  Options o;
  add_options(app, o);
  CLI11_PARSE(app, argc, argv);
  o.work = fs::absolute(o.work).lexically_normal().string();
  if (!bench::arscout_runnable(o.arscout)) return 2;
  if (o.real.empty() && !o.no_real) o.real = default_real_scenes();
  std::cout << "dense_quality: arscout reconstruct --dense, block walks of "
            << o.views << " photos (" << o.width << " x " << o.height
            << "), dense long side " << o.dense_long_side << "\n"
            << bench::machine_summary() << std::endl;
  std::vector<Row> rows;
  try {
    if (!o.no_block)
      for (int seed : o.seeds) rows.push_back(measure_block(o, seed));
    for (const std::string& scene : o.real)
      rows.push_back(measure_real(o, scene));
  } catch (const std::exception& e) {
    std::cerr << "dense_quality: " << e.what() << std::endl;
    return 2;
  }
  print_rows(rows);
  if (o.mesh) print_mesh_rows(rows);
  print_completeness_by_views(rows);
  const bool met = print_targets(rows);
  return o.check && !met ? 1 : 0;
}
