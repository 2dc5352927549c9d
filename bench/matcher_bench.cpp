// matcher_bench: the full descriptor match of two photos (the engine's
// largest cost per photo) and the overlap screen, at several feature
// counts, on this CPU's kernel. The descriptors are RootSIFT-like rows made
// here (non-negative, unit length, with a share of true correspondences),
// so no data is needed. Prints one table row per size: milliseconds per
// pair (the fastest of --repeat), matches found, and how the cost grows.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include <CLI/CLI.hpp>
#include <opencv2/core.hpp>

#include "features/matcher.h"

namespace {

// `n` unit rows of 128 non-negative components: the square roots of
// normalized gamma-like histograms, as RootSIFT's are.
cv::Mat random_rows(int n, std::mt19937& rng) {
  std::gamma_distribution<float> bin(0.6f, 1.0f);
  cv::Mat rows(n, 128, CV_32F);
  for (int r = 0; r < n; ++r) {
    float* row = rows.ptr<float>(r);
    float sum = 0;
    for (int k = 0; k < 128; ++k) sum += row[k] = bin(rng);
    for (int k = 0; k < 128; ++k) row[k] = std::sqrt(row[k] / sum);
  }
  return rows;
}

// A copy of `a` with a share of its rows perturbed slightly (the same
// features seen again) and the rest replaced by new ones.
cv::Mat second_view(const cv::Mat& a, double shared, std::mt19937& rng) {
  cv::Mat b = random_rows(a.rows, rng);
  std::normal_distribution<float> noise(0.0f, 0.02f);
  for (int r = 0; r < a.rows * shared; ++r) {
    float* row = b.ptr<float>(r);
    double norm = 0;
    for (int k = 0; k < 128; ++k) {
      row[k] = std::max(0.0f, a.ptr<float>(r)[k] + noise(rng));
      norm += row[k] * row[k];
    }
    for (int k = 0; k < 128; ++k) row[k] /= static_cast<float>(std::sqrt(norm));
  }
  return b;
}

template <typename F>
double fastest_ms(int repeat, F&& f) {
  double best = 1e300;
  for (int i = 0; i < repeat; ++i) {
    const auto start = std::chrono::steady_clock::now();
    f();
    best = std::min(best, std::chrono::duration<double, std::milli>(
                              std::chrono::steady_clock::now() - start)
                              .count());
  }
  return best;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"matcher_bench: full descriptor matches per pair on this CPU"};
  std::vector<int> sizes{1000, 2000, 3000};
  int repeat = 3, threads = 1;
  app.add_option("--features", sizes, "feature counts per photo")
      ->capture_default_str();
  app.add_option("--repeat", repeat, "runs per size; the fastest is kept")
      ->capture_default_str();
  app.add_option("--threads", threads, "threads per match")
      ->capture_default_str();
  bool float_rows = false;
  app.add_flag("--float", float_rows,
               "one component made negative: the float kernel instead of "
               "the 12-bit codes");
  CLI11_PARSE(app, argc, argv);
  std::printf("kernel %s, %d thread(s)\n", arscout::engine::matcher_kernel(),
              threads);
  std::printf(
      "| features | match ms/pair | matches | x first size per n^2 "
      "| screen ms (256 rows) |\n|---|---|---|---|---|\n");
  std::mt19937 rng(7);
  double first_per_n2 = 0;
  for (int n : sizes) {
    cv::Mat a = random_rows(n, rng);
    if (float_rows) a.at<float>(0, 0) = -1e-7f;  // the float path
    const cv::Mat b = second_view(a, 0.3, rng);
    size_t found = 0;
    const double ms = fastest_ms(repeat, [&] {
      found = arscout::engine::match_descriptors(a, b, 0.8, threads).size();
    });
    const double screen = fastest_ms(
        repeat, [&] { arscout::engine::overlap_score(a, b, 0.8, 256); });
    const double per_n2 = ms / (double(n) * n);
    if (first_per_n2 == 0) first_per_n2 = per_n2;
    std::printf("| %d | %.2f | %zu | %.2f | %.2f |\n", n, ms, found,
                per_n2 / first_per_n2, screen);
  }
  return 0;
}
