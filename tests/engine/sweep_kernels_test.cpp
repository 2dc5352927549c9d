// The plane sweep's row kernels (engine/src/dense/sweep_kernels.h) against
// plain references: OpenCV's warp, direct window sums, the ZNCC formula;
// and the whole sweep's independence of the thread count.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include <Eigen/Dense>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include "arscout/engine/dense.h"
#include "arscout/engine/synthetic_site.h"
#include "dense/sweep_kernels.h"

namespace arscout::engine {
namespace {

namespace k = sweep_kernels;

cv::Mat random_grey(cv::Size size, uint32_t seed) {
  cv::Mat grey(size, CV_32F);
  cv::RNG rng(seed);
  rng.fill(grey, cv::RNG::UNIFORM, 0, 256);
  grey.forEach<float>([](float& v, const int*) { v = std::floor(v); });
  return grey;
}

TEST(SweepKernels, WarpRowMatchesWarpPerspective) {
  const cv::Mat grey = random_grey({97, 61}, 3);
  cv::Mat padded;
  cv::copyMakeBorder(grey, padded, k::kGreyPad, k::kGreyPad, k::kGreyPad,
                     k::kGreyPad, cv::BORDER_CONSTANT, 0);
  const k::PaddedGrey source{padded.ptr<float>(),
                             static_cast<int>(padded.step1()), grey.cols,
                             grey.rows};
  // A mild projective map that leaves part of the row outside the image.
  const cv::Matx33d H(0.93, 0.05, 7.3, -0.04, 1.02, -3.1, 2e-4, -1e-4, 1);
  cv::Mat expected;
  cv::warpPerspective(grey, expected, cv::Mat(H), cv::Size(112, 64),
                      cv::INTER_LINEAR | cv::WARP_INVERSE_MAP,
                      cv::BORDER_CONSTANT, 0);
  const float h[9] = {0.93f, 0.05f, 7.3f,   -0.04f, 1.02f,
                      -3.1f, 2e-4f, -1e-4f, 1.0f};
  std::vector<float> xs(112), a(112, 1.0f), b(112), bb(112), ab(112),
      inside(112);
  for (int x = 0; x < 112; ++x) xs[x] = static_cast<float>(x);
  int compared = 0, inside_count = 0;
  for (int y = 0; y < 64; ++y) {
    k::warp_row(h, static_cast<float>(y), xs.data(), 112, source, 4, a.data(),
                b.data(), bb.data(), ab.data(), inside.data());
    for (int x = 0; x < 112; ++x) {
      const float sample = b[x] + k::kGreyCentre;
      // Float positions may fall on the other side of a 1/32 grid line
      // than OpenCV's double ones: one grid step of one grey-level slope.
      EXPECT_NEAR(sample, expected.at<float>(y, x), 256.0 / 32 + 1e-3)
          << x << "," << y;
      compared += std::abs(sample - expected.at<float>(y, x)) < 1e-3f;
      EXPECT_FLOAT_EQ(bb[x], b[x] * b[x]);
      EXPECT_FLOAT_EQ(ab[x], b[x]);
      const double w = H(2, 0) * x + H(2, 1) * y + H(2, 2);
      const double u = (H(0, 0) * x + H(0, 1) * y + H(0, 2)) / w;
      const double v = (H(1, 0) * x + H(1, 1) * y + H(1, 2)) / w;
      const bool in = u >= 4 && v >= 4 && u <= 96 - 4 && v <= 60 - 4;
      EXPECT_EQ(inside[x], in ? 1.0f : 0.0f) << x << "," << y;
      inside_count += in;
    }
  }
  EXPECT_GT(compared, 112 * 64 * 95 / 100);  // nearly all bit-equal
  EXPECT_GT(inside_count, 1000);
  EXPECT_LT(inside_count, 112 * 64);  // some of the row is outside
}

TEST(SweepKernels, RowSumsMatchDirectSums) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> value(-128, 128);
  const int count = 40, n = 7;
  std::vector<float> in(count + n), out(count);
  for (float& v : in) v = value(rng);
  k::sum_runs(in.data(), n, count, out.data());
  for (int i = 0; i < count; ++i) {
    float expected = in[i];
    for (int j = 1; j < n; ++j) expected += in[i + j];
    EXPECT_EQ(out[i], expected) << i;  // same order of additions
  }
  std::vector<std::vector<float>> rows(n + 1, std::vector<float>(count));
  for (auto& row : rows)
    for (float& v : row) v = value(rng);
  std::vector<const float*> first(n), second(n);
  for (int j = 0; j < n; ++j) {
    first[j] = rows[j].data();
    second[j] = rows[j + 1].data();
  }
  std::vector<float> sums(count), direct(count);
  k::sum_rows(first.data(), n, count, sums.data());
  k::slide_rows(sums.data(), rows[n].data(), rows[0].data(), count);
  k::sum_rows(second.data(), n, count, direct.data());
  for (int i = 0; i < count; ++i) EXPECT_NEAR(sums[i], direct[i], 1e-3) << i;
}

TEST(SweepKernels, ZnccRowScoresMaskedPixelsOnly) {
  // Window sums of a 1-pixel "window" (n = 1) make the formula easy to
  // check: var_b = 0 means flat, hence unscored.
  const int count = 8;
  const float inverse_n = 1.0f / 4;
  // Four samples per pixel: b = {1, 2, 3, 4} + offset, a = {2, 4, 6, 8}.
  std::vector<float> sb(count, 10), sbb(count, 30), sab(count, 60);
  std::vector<float> inside(count, 1), mean_a(count, 5), inv_a(count);
  for (float& v : inv_a) v = 1 / std::sqrt(5.0f);  // var_a = 5
  inside[1] = 0;                                   // outside the neighbour
  inv_a[2] = 0;                                    // no key texture
  sbb[3] = 25;  // flat: var_b = 25/4 - 2.5^2 = 0
  std::vector<float> best(count, k::kNoScore), sum(count, 0), hits(count, 0);
  k::zncc_row(sb.data(), sbb.data(), sab.data(), inside.data(), mean_a.data(),
              inv_a.data(), inverse_n, count, best.data(), sum.data(),
              hits.data());
  for (int i = 0; i < count; ++i) {
    if (i >= 1 && i <= 3) {
      EXPECT_EQ(best[i], k::kNoScore) << i;
      EXPECT_EQ(hits[i], 0) << i;
    } else {
      EXPECT_NEAR(best[i], 1.0, 1e-5) << i;  // b is a linear function of a
      EXPECT_EQ(hits[i], 1) << i;
      EXPECT_NEAR(sum[i], 1.0, 1e-5) << i;
    }
  }
}

TEST(SweepKernels, SweepIsTheSameOnOneThreadAndOnSeveral) {
  const synthetic::Site site = synthetic::street_site(3);
  std::vector<DenseView> views;
  for (const auto& view : synthetic::street_cameras(3, {320, 240}, 280)) {
    const synthetic::Rendering r = synthetic::render(site, view, 2);
    DenseView v;
    v.id = std::to_string(views.size());
    v.bgr = r.bgr;
    v.K = view.K;
    v.R = view.R;
    v.t = view.t;
    for (int i = 0; i < static_cast<int>(r.depth.total()); i += 53) {
      const int x = i % r.depth.cols, y = i / r.depth.cols;
      const float z = r.depth.at<float>(y, x);
      if (z <= 0) continue;
      v.sparse_points.push_back(
          v.R.transpose() *
          (z * (v.K.inverse() * Eigen::Vector3d(x, y, 1)) - v.t));
    }
    views.push_back(std::move(v));
  }
  const std::vector<const DenseView*> neighbours = {&views[0], &views[2]};
  const int threads = cv::getNumThreads();
  cv::setNumThreads(1);
  const DepthMap one = sweep_planes(views[1], neighbours, {});
  cv::setNumThreads(4);
  const DepthMap several = sweep_planes(views[1], neighbours, {});
  // Kept on the calling thread (PlaneSweepOptions::parallel false): the
  // same map again.
  PlaneSweepOptions serial;
  serial.parallel = false;
  const DepthMap here = sweep_planes(views[1], neighbours, serial);
  // Asked before each group of strips (PlaneSweepOptions::keep_parallel),
  // answering yes and no in turn: the same map, and it was asked.
  PlaneSweepOptions asked;
  int questions = 0;
  asked.keep_parallel = [&questions] { return ++questions % 2 == 0; };
  const DepthMap mixed = sweep_planes(views[1], neighbours, asked);
  cv::setNumThreads(threads);
  EXPECT_GE(questions, 2);
  EXPECT_EQ(cv::norm(mixed.depth, several.depth, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(mixed.score, several.score, cv::NORM_INF), 0);
  EXPECT_GT(one.coverage(), 0.5);
  EXPECT_EQ(cv::norm(one.depth, several.depth, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(one.score, several.score, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(here.depth, several.depth, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(here.score, several.score, cv::NORM_INF), 0);
}

}  // namespace
}  // namespace arscout::engine
