// dense_bench: plane-sweep throughput on a rendered street scene (no data
// needed), the figures issue 5 asks for: pixel-plane-view evaluations per
// second, and the time of one depth map at about 1 MP with 128 planes.
//
//   dense_bench [--width 1224] [--height 816] [--planes 128] [--repeat 5]
//               [--threads 2] [--auto [--catch-up]] [--cuda]
//
// One evaluation is one key pixel scored against one neighbour on one
// plane. The key view is the middle of three converging street cameras and
// sweeps against the other two. By default it sweeps --planes
// fronto-parallel planes only, so the count is exact; --auto uses the
// default options instead (scene directions, plane count from the
// baseline) and reports the count they chose; --catch-up, with --auto, the
// options a dense lane that fell behind sweeps with (catch_up_sweep). Each
// sweep is timed --repeat times; the table gives the median and the fastest.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <Eigen/Dense>
#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>

#include "arscout/engine/dense.h"
#include "arscout/engine/dense_reconstruction.h"
#include "arscout/engine/synthetic_site.h"
#include "arscout/util/clock.h"

namespace {

namespace syn = arscout::engine::synthetic;
using arscout::engine::DenseView;
using arscout::engine::PlaneSweepOptions;
using Clock = std::chrono::steady_clock;

struct Scene {
  std::vector<DenseView> views;  // views[1] is the key
};

// Every 97th pixel's exact surface point, as the sparse points the key sees.
std::vector<Eigen::Vector3d> surface_points(const syn::PinholeView& view,
                                            const cv::Mat& depth) {
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < static_cast<int>(depth.total()); i += 97) {
    const int x = i % depth.cols, y = i / depth.cols;
    const float z = depth.at<float>(y, x);
    if (z <= 0) continue;
    const Eigen::Vector3d ray = view.K.inverse() * Eigen::Vector3d(x, y, 1);
    points.push_back(view.R.transpose() * (z * ray - view.t));
  }
  return points;
}

Scene render_scene(cv::Size size) {
  const syn::Site site = syn::street_site(3);
  Scene scene;
  int index = 0;
  for (const auto& view :
       syn::street_cameras(3, size, 560.0 * size.width / 640.0)) {
    const syn::Rendering image = syn::render(site, view, 2);
    DenseView v;
    v.id = "view" + std::to_string(index++);
    v.bgr = image.bgr;
    v.K = view.K;
    v.R = view.R;
    v.t = view.t;
    v.sparse_points = surface_points(view, image.depth);
    scene.views.push_back(std::move(v));
  }
  return scene;
}

using arscout::util::seconds_since;

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Plane-sweep throughput on a rendered street scene"};
  int width = 1224, height = 816, planes = 128, repeat = 5, threads = 2;
  bool automatic = false, catch_up = false, cuda = false;
  app.add_option("--width", width, "key image width")
      ->check(CLI::PositiveNumber);
  app.add_option("--height", height, "key image height")
      ->check(CLI::PositiveNumber);
  app.add_option("--planes", planes, "fronto-parallel planes")
      ->check(CLI::Range(3, 4096));
  app.add_option("--repeat", repeat, "timed sweeps")
      ->check(CLI::PositiveNumber);
  app.add_option("--threads", threads, "OpenCV worker threads")
      ->check(CLI::PositiveNumber);
  app.add_flag("--auto", automatic,
               "default options: scene directions, planes from the baseline");
  app.add_flag("--catch-up", catch_up,
               "with --auto: planes twice as far apart, as a dense lane "
               "that fell behind sweeps");
  app.add_flag("--cuda", cuda, "the CUDA path (when built with ARSCOUT_CUDA)");
  CLI11_PARSE(app, argc, argv);
  cv::setNumThreads(threads);

  std::fprintf(stderr, "rendering %dx%d street scene...\n", width, height);
  const Scene scene = render_scene(cv::Size(width, height));
  const DenseView& key = scene.views[1];
  const std::vector<const DenseView*> neighbours = {&scene.views[0],
                                                    &scene.views[2]};
  PlaneSweepOptions options;
  options.use_cuda = cuda;
  if (!automatic) {
    options.max_scene_directions = 0;
    options.min_planes = options.max_planes = planes;
  } else if (catch_up) {
    options = arscout::engine::catch_up_sweep(options);
  }
  long long plane_count = 0;
  for (const auto& d :
       arscout::engine::sweep_directions(key, neighbours, options))
    plane_count += d.planes;
  const double evaluations =
      static_cast<double>(plane_count) * neighbours.size() * key.bgr.total();

  std::vector<double> seconds;
  double coverage = 0;
  for (int i = 0; i < repeat; ++i) {
    const auto start = Clock::now();
    const auto map = arscout::engine::sweep_planes(key, neighbours, options);
    seconds.push_back(seconds_since(start));
    coverage = map.coverage();
    std::fprintf(stderr, "sweep %d/%d: %.3f s\n", i + 1, repeat,
                 seconds.back());
  }
  std::sort(seconds.begin(), seconds.end());
  const double median = seconds[seconds.size() / 2];
  char date[32];
  const std::time_t now = std::time(nullptr);
  std::strftime(date, sizeof date, "%Y-%m-%d %H:%M UTC", std::gmtime(&now));
  std::printf(
      "| image | planes (all directions) | neighbours | threads | "
      "median s | fastest s | M evaluations/s (median) | coverage |\n");
  std::printf("|---|---|---|---|---|---|---|---|\n");
  std::printf("| %dx%d | %lld | %zu | %d | %.3f | %.3f | %.0f | %.1f %% |\n",
              width, height, plane_count, neighbours.size(), threads, median,
              seconds.front(), evaluations / median / 1e6, 100 * coverage);
  std::printf("\n%s, %s path\n", date, cuda ? "CUDA" : "CPU");
  return 0;
}
