// scale_bench: how `arscout reconstruct` holds up over a long scouting walk.
// For each seed, `arscout render-site --scene block` renders a loop walk of
// --views photos round a synthetic city block with exact poses and noisy GPS
// (reused when WORK/seedS/site already holds that rendering), and
// `arscout reconstruct` runs on it as a child process (its log in
// WORK/seedS/reconstruct.log, each camera's error in camera_errors.csv).
// Per seed, and the median over the seeds:
//
//   - registered photos, of --views;
//   - the median and max camera-centre error after a 7-DoF similarity fit
//     to the true poses, in metres;
//   - the median distance of cameras_geo.csv from the noise-free fixes;
//   - the sparse increment (a photo's `total` on its progress line, the
//     background refinement not included): its p50 and max over all photos,
//     its p95 over photos 21-120 and over the last 100, and their ratio,
//     which is 1 when the cost of a photo does not grow with the model;
//   - the refinement's seconds in all, the wall time, and the child's peak
//     resident memory (wait4).
//
// Targets: registered >= 98 %, centre error median <= 0.02 m and max <=
// 0.10 m, geo median <= 0.5 m, p95 ratio <= 1.25, max increment <= 3 s.
//
//   scale_bench [--views 400] [--seeds 1,2,3] [--width 1024] [--height 768]
//               [--work /tmp/arscout-scale-bench] [--arscout PATH]
//               [--reconstruct-args "..."] [--check]
//
// With --check it exits 1 when a seed misses a target. Percentiles
// interpolate linearly (eval::percentile). Below 220 photos the windows
// shrink: photos 21..min(120, N/2) and the last min(100, N/2).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "bench_support.h"
#include "child_process.h"
#include "model_eval.h"
#include "progress_log.h"

namespace {

namespace fs = std::filesystem;
namespace ev = arscout::eval;
namespace bench = arscout::bench;
using bench::fixed;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

struct Options {
  int views = 400;
  std::vector<int> seeds = {1, 2, 3};
  int width = 1024;
  int height = 768;
  std::string work = "/tmp/arscout-scale-bench";
  std::string arscout = ARSCOUT_EXE;
  std::string reconstruct_args;
  bool check = false;
};

struct Row {
  std::string label;  // "seed 1", "median"
  std::string error;  // why the figures are missing, or ""
  double registered = kNaN, registered_pct = kNaN;
  double centre_median_m = kNaN, centre_max_m = kNaN, geo_median_m = kNaN;
  double inc_p50_s = kNaN, p95_first_s = kNaN, p95_last_s = kNaN;
  double ratio = kNaN, inc_max_s = kNaN;
  double refine_s = kNaN, wall_s = kNaN, peak_rss_mib = kNaN;
};

void render_site(const Options& o, int seed, const fs::path& dir) {
  bench::render_block_walk(
      o.arscout, {o.views, seed, o.width, o.height}, (dir / "site").string(),
      (dir / "render.log").string(), "seed " + std::to_string(seed));
}

std::vector<std::string> reconstruct_args(const Options& o,
                                          const fs::path& dir) {
  const std::string site = (dir / "site").string();
  std::vector<std::string> args = {
      "reconstruct",         "--images", site + "/images",       "--gps-csv",
      site + "/gps.csv",     "--camera", site + "/images/K.txt", "--out",
      (dir / "out").string()};
  std::istringstream extra(o.reconstruct_args);
  for (std::string word; extra >> word;) args.push_back(word);
  return args;
}

// The figures of one finished run: its outputs against the truth, and its
// progress log.
// The increment figures of a finished run's progress log.
void measure_increments(const Options& o, const fs::path& dir, Row& row) {
  const ev::ProgressLog log =
      ev::read_progress_log((dir / "reconstruct.log").string());
  const bench::WalkWindows w = bench::walk_windows(o.views);
  const std::vector<double> all = ev::increments(log, 1, o.views);
  row.inc_p50_s = ev::percentile(all, 0.5);
  row.inc_max_s = ev::percentile(all, 1.0);
  row.p95_first_s =
      ev::percentile(ev::increments(log, w.first_begin, w.first_end), 0.95);
  row.p95_last_s =
      ev::percentile(ev::increments(log, w.last_begin, w.last_end), 0.95);
  row.ratio = row.p95_last_s / row.p95_first_s;
  row.refine_s = log.refine_seconds();
}

// Each camera's error after the similarity fit, by name, for finding where
// along the walk a model goes wrong.
void write_camera_errors(const ev::PoseComparison& poses,
                         const fs::path& path) {
  std::ofstream out(path);
  out << "name,centre_m,rotation_deg,along_axis_m,across_axis_m\n";
  for (const auto& c : poses.cameras)
    out << c.name << "," << c.centre_error << "," << c.rotation_error_deg << ","
        << c.along_axis_error << "," << c.across_axis_error << "\n";
}

// A finished run's outputs against the truth.
void measure_accuracy(const Options& o, const fs::path& dir, Row& row) {
  const std::string site = (dir / "site").string();
  const std::string out = (dir / "out").string();
  const auto estimated = ev::read_colmap_images_txt(out + "/sparse/images.txt");
  const auto truth = ev::read_strecha_ground_truth(site + "/gt_dense_cameras");
  int registered = 0;
  for (const auto& [name, pose] : estimated) registered += truth.count(name);
  row.registered = registered;
  row.registered_pct = 100.0 * registered / o.views;
  if (registered < 3)  // the similarity fit needs three cameras
    throw std::runtime_error(std::to_string(registered) + " registered");
  const auto poses = ev::compare_to_ground_truth(estimated, truth);
  write_camera_errors(poses, dir / "camera_errors.csv");
  row.centre_median_m = poses.median_centre_error;
  row.centre_max_m = poses.max_centre_error;
  row.geo_median_m = ev::median_geo_distance(
      ev::read_geo_csv(out + "/cameras_geo.csv"),
      ev::read_geo_csv(site + "/gps_truth.csv"), nullptr);
}

Row measure_seed(const Options& o, int seed) {
  const fs::path dir = fs::path(o.work) / ("seed" + std::to_string(seed));
  fs::create_directories(dir);
  render_site(o, seed, dir);
  fs::remove_all(dir / "out");
  std::cerr << "seed " << seed << ": reconstructing" << std::endl;
  const std::string log = (dir / "reconstruct.log").string();
  const bench::ChildResult r =
      bench::run_child(o.arscout, reconstruct_args(o, dir), log);
  Row row;
  row.label = "seed " + std::to_string(seed);
  row.wall_s = r.wall_s;
  row.peak_rss_mib = static_cast<double>(r.max_rss_kib) / 1024.0;
  if (!bench::exited_ok(r)) {
    row.error = "reconstruct failed (see " + log + ")";
    std::cerr << row.error << ":\n" << bench::last_lines(log, 5);
    return row;
  }
  try {
    measure_increments(o, dir, row);
    measure_accuracy(o, dir, row);
  } catch (const std::exception& e) {
    row.error = e.what();
    std::cerr << "seed " << seed << ": " << e.what() << std::endl;
  }
  return row;
}

// Each column's median over the seeds that have it.
Row median_row(const std::vector<Row>& rows) {
  Row m;
  m.label = "median";
  auto med = [&](double Row::*field) {
    std::vector<double> values;
    for (const Row& r : rows)
      if (!std::isnan(r.*field)) values.push_back(r.*field);
    return ev::median(values);
  };
  for (double Row::*field :
       {&Row::registered, &Row::registered_pct, &Row::centre_median_m,
        &Row::centre_max_m, &Row::geo_median_m, &Row::inc_p50_s,
        &Row::p95_first_s, &Row::p95_last_s, &Row::ratio, &Row::inc_max_s,
        &Row::refine_s, &Row::wall_s, &Row::peak_rss_mib})
    m.*field = med(field);
  return m;
}

struct Target {
  std::string name;
  bool (*met)(const Row&);
};

// NaN compares false, so a missing figure misses its target.
const std::vector<Target>& targets() {
  static const std::vector<Target> all = {
      {"registered >= 98 %",
       [](const Row& r) { return r.registered_pct >= 98; }},
      {"centre median <= 0.02 m, max <= 0.10 m",
       [](const Row& r) {
         return r.centre_median_m <= 0.02 && r.centre_max_m <= 0.10;
       }},
      {"geo median <= 0.5 m",
       [](const Row& r) { return r.geo_median_m <= 0.5; }},
      {"p95 ratio <= 1.25", [](const Row& r) { return r.ratio <= 1.25; }},
      {"max increment <= 3 s", [](const Row& r) { return r.inc_max_s <= 3; }},
  };
  return all;
}

void print_header(const Options& o) {
  const bench::WalkWindows w = bench::walk_windows(o.views);
  std::cout << "scale_bench: arscout reconstruct on a synthetic block walk "
            << "(render-site --scene block), " << o.views << " photos of "
            << o.width << " x " << o.height << "\n"
            << bench::machine_summary() << "arscout: " << o.arscout << "\n"
            << "increment windows: photos " << w.first_begin << "-"
            << w.first_end << " and " << w.last_begin << "-" << w.last_end
            << (w.shrunk ? " (fewer than 220 photos: 21..min(120, N/2) and "
                           "the last min(100, N/2))"
                         : "")
            << "\n";
  if (!o.reconstruct_args.empty())
    std::cout << "reconstruct args: " << o.reconstruct_args << "\n";
  std::cout << std::endl;
}

void print_figures(const std::vector<Row>& rows, const bench::WalkWindows& w,
                   int views) {
  const std::string first =
      std::to_string(w.first_begin) + "-" + std::to_string(w.first_end);
  const std::string last =
      std::to_string(w.last_begin) + "-" + std::to_string(w.last_end);
  std::cout << "| run | registered | centre median m | centre max m | "
               "geo median m | increment p50 s | p95 "
            << first << " s | p95 " << last
            << " s | ratio | max increment s | refine s | wall s | "
               "peak RSS MiB |\n"
            << "|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const Row& r : rows) {
    std::cout << "| " << r.label << " | " << fixed(r.registered, 0) << "/"
              << views << " (" << fixed(r.registered_pct, 1) << " %) | "
              << fixed(r.centre_median_m, 4) << " | "
              << fixed(r.centre_max_m, 4) << " | " << fixed(r.geo_median_m, 3)
              << " | " << fixed(r.inc_p50_s, 2) << " | "
              << fixed(r.p95_first_s, 2) << " | " << fixed(r.p95_last_s, 2)
              << " | " << fixed(r.ratio, 2) << " | " << fixed(r.inc_max_s, 2)
              << " | " << fixed(r.refine_s, 1) << " | " << fixed(r.wall_s, 1)
              << " | " << fixed(r.peak_rss_mib, 0) << " |\n";
  }
  std::cout << std::endl;
}

// The PASS/FAIL table; true when every seed row meets every target.
bool print_targets(const std::vector<Row>& rows) {
  std::cout << "| run |";
  for (const Target& t : targets()) std::cout << " " << t.name << " |";
  std::cout << "\n|---|";
  for (std::size_t i = 0; i < targets().size(); ++i) std::cout << "---|";
  std::cout << "\n";
  bool all_met = true;
  for (const Row& r : rows) {
    std::cout << "| " << r.label << " |";
    for (const Target& t : targets()) {
      const bool met = t.met(r);
      if (r.label != "median") all_met = all_met && met;
      std::cout << (met ? " PASS |" : " FAIL |");
    }
    std::cout << "\n";
  }
  for (const Row& r : rows)
    if (!r.error.empty()) std::cout << r.label << ": " << r.error << "\n";
  std::cout << std::endl;
  return all_met;
}

void add_options(CLI::App& app, Options& o) {
  app.add_option("--views", o.views, "photos in each walk")
      ->check(CLI::Range(1, 1000));
  app.add_option("--seeds", o.seeds, "block seeds, comma-separated")
      ->delimiter(',');
  app.add_option("--width", o.width, "photo width, px");
  app.add_option("--height", o.height, "photo height, px");
  app.add_option(
      "--work", o.work,
      "work folder: WORK/seedS/{site,out,reconstruct.log,camera_errors.csv}");
  app.add_option("--arscout", o.arscout, "the arscout executable");
  app.add_option("--reconstruct-args", o.reconstruct_args,
                 "extra arguments for arscout reconstruct, space-separated");
  app.add_flag("--check", o.check, "exit 1 when a seed misses a target");
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"scale_bench: arscout reconstruct over a synthetic block walk"};
  Options o;
  add_options(app, o);
  CLI11_PARSE(app, argc, argv);
  o.work = fs::absolute(o.work).lexically_normal().string();
  if (!bench::arscout_runnable(o.arscout)) return 2;
  print_header(o);
  std::vector<Row> rows;
  try {
    for (int seed : o.seeds) rows.push_back(measure_seed(o, seed));
  } catch (const std::exception& e) {
    std::cerr << "scale_bench: " << e.what() << std::endl;
    return 2;
  }
  rows.push_back(median_row(rows));
  print_figures(rows, bench::walk_windows(o.views), o.views);
  const bool met = print_targets(rows);
  return o.check && !met ? 1 : 0;
}
