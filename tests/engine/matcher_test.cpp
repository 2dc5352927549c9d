// Descriptor matching on synthetic RootSIFT-like rows where the true
// correspondence is known: b holds noisy copies of some of a's rows in a
// shuffled order, plus distractors.
#include "features/matcher.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <numeric>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

namespace arscout::engine {
namespace {

constexpr int kDim = 128;
constexpr double kRatio = 0.8;

// Non-negative unit rows, as RootSIFT descriptors are: unrelated ones sit
// about 0.85 apart, not sqrt(2), which makes the ratio test's job realistic.
void fill_random_row(float* row, std::mt19937& rng) {
  std::normal_distribution<float> n(0, 1);
  for (int k = 0; k < kDim; ++k) row[k] = std::abs(n(rng));
}

void add_noise(float* row, std::mt19937& rng, float sigma) {
  std::normal_distribution<float> n(0, sigma);
  for (int k = 0; k < kDim; ++k) row[k] = std::max(0.0f, row[k] + n(rng));
}

void normalize_rows(cv::Mat& m) {
  for (int r = 0; r < m.rows; ++r) {
    float* row = m.ptr<float>(r);
    float norm = 0;
    for (int k = 0; k < kDim; ++k) norm += row[k] * row[k];
    for (int k = 0; k < kDim; ++k) row[k] /= std::sqrt(norm);
  }
}

// 600 rows in a (more than 256 per thread, so two threads really split the
// work); the first 400 have a noisy copy in b at a shuffled position, the
// other 200 have none. b also holds 300 distractors; rows 10-19 of a get a
// second, near-identical copy in b (ambiguous: the ratio test must reject
// them), and row 550 of a is an exact duplicate of row 5 (a tie: the lower
// index wins).
struct MatchData {
  cv::Mat a, b;
  std::vector<std::pair<int, int>> expected;  // sorted by a's row
};

constexpr int kRowsA = 600;
constexpr int kPartnered = 400;
constexpr int kDistractors = 300;
constexpr int kAmbiguousBegin = 10, kAmbiguousEnd = 20;
constexpr int kTieLow = 5, kTieHigh = 550;

MatchData make_match_data(uint32_t seed) {
  std::mt19937 rng(seed);
  MatchData data;
  data.a = cv::Mat(kRowsA, kDim, CV_32F);
  for (int r = 0; r < kRowsA; ++r) fill_random_row(data.a.ptr<float>(r), rng);
  normalize_rows(data.a);
  data.a.row(kTieLow).copyTo(data.a.row(kTieHigh));

  const int ambiguous = kAmbiguousEnd - kAmbiguousBegin;
  const int rows_b = kPartnered + kDistractors + ambiguous;
  std::vector<int> position(rows_b);  // shuffled slot of each b row
  std::iota(position.begin(), position.end(), 0);
  std::shuffle(position.begin(), position.end(), rng);
  data.b = cv::Mat(rows_b, kDim, CV_32F);
  for (int i = 0; i < kPartnered; ++i) {
    float* row = data.b.ptr<float>(position[i]);
    std::copy(data.a.ptr<float>(i), data.a.ptr<float>(i) + kDim, row);
    add_noise(row, rng, 0.01f);  // ~0.15 from its original, vs ~0.85 for others
  }
  for (int i = 0; i < kDistractors; ++i) {
    fill_random_row(data.b.ptr<float>(position[kPartnered + i]), rng);
  }
  for (int i = 0; i < ambiguous; ++i) {
    float* row = data.b.ptr<float>(position[kPartnered + kDistractors + i]);
    std::copy(data.b.ptr<float>(position[kAmbiguousBegin + i]),
              data.b.ptr<float>(position[kAmbiguousBegin + i]) + kDim, row);
    add_noise(row, rng, 0.001f);
  }
  normalize_rows(data.b);
  for (int i = 0; i < kPartnered; ++i) {
    if (i >= kAmbiguousBegin && i < kAmbiguousEnd) continue;
    data.expected.emplace_back(i, position[i]);
  }
  return data;
}

TEST(MatcherTest, FindsExactlyTheTruePairs) {
  const MatchData data = make_match_data(1);
  const auto matches = match_descriptors(data.a, data.b, kRatio, 1);
  // Every unambiguous partnered row, nothing else: no distractor, no row
  // without a partner, neither copy of an ambiguous row, and the duplicate
  // row 550 loses its tie with row 5.
  EXPECT_EQ(matches, data.expected);
}

TEST(MatcherTest, RatioTestRejectsAmbiguousRows) {
  const MatchData data = make_match_data(2);
  const auto matches = match_descriptors(data.a, data.b, kRatio, 1);
  for (const auto& [i, j] : matches) {
    EXPECT_FALSE(i >= kAmbiguousBegin && i < kAmbiguousEnd) << "row " << i;
  }
  // With the ratio test effectively off (any second-nearest passes), the
  // ambiguous rows do match one of their two copies: the rejection above is
  // the ratio test's doing, not the mutual check's.
  const auto loose = match_descriptors(data.a, data.b, 1.01, 1);
  int ambiguous_matched = 0;
  for (const auto& [i, j] : loose) {
    if (i >= kAmbiguousBegin && i < kAmbiguousEnd) ++ambiguous_matched;
  }
  EXPECT_EQ(ambiguous_matched, kAmbiguousEnd - kAmbiguousBegin);
}

TEST(MatcherTest, TiesGoToTheLowerIndex) {
  const MatchData data = make_match_data(3);
  const auto matches = match_descriptors(data.a, data.b, kRatio, 2);
  const auto has_row = [&](int row) {
    return std::any_of(matches.begin(), matches.end(),
                       [&](const auto& m) { return m.first == row; });
  };
  EXPECT_TRUE(has_row(kTieLow));
  EXPECT_FALSE(has_row(kTieHigh));
}

TEST(MatcherTest, ResultDoesNotDependOnThreads) {
  const MatchData data = make_match_data(4);
  const auto one = match_descriptors(data.a, data.b, kRatio, 1);
  EXPECT_EQ(one, data.expected);
  EXPECT_EQ(match_descriptors(data.a, data.b, kRatio, 2), one);
  EXPECT_EQ(match_descriptors(data.a, data.b, kRatio, 3), one);
  EXPECT_EQ(match_descriptors(data.a, data.b, kRatio, 0), one);  // clamps to 1
  // Swapping the roles finds the same pairs (the mutual check is
  // symmetric), except where the test is not: from b's side the closer copy
  // of an ambiguous row is unambiguous, and rows 5 and 550 are equally near
  // their partner, which the ratio test rejects.
  auto swapped = match_descriptors(data.b, data.a, kRatio, 2);
  for (auto& [i, j] : swapped) std::swap(i, j);
  std::sort(swapped.begin(), swapped.end());
  std::erase_if(swapped, [](const auto& m) {
    return m.first >= kAmbiguousBegin && m.first < kAmbiguousEnd;
  });
  std::vector<std::pair<int, int>> expected = one;
  std::erase_if(expected, [](const auto& m) { return m.first == kTieLow; });
  EXPECT_EQ(swapped, expected);
}

TEST(MatcherTest, RowCountsNotMultipleOfBlock) {
  // 7 rows in a (a tail shorter than the four-row block) against 5 in b.
  std::mt19937 rng(5);
  cv::Mat a(7, kDim, CV_32F), b(5, kDim, CV_32F);
  for (int r = 0; r < a.rows; ++r) fill_random_row(a.ptr<float>(r), rng);
  normalize_rows(a);
  const int partner[5] = {6, 0, 4, 2, 5};
  for (int j = 0; j < b.rows; ++j) {
    std::copy(a.ptr<float>(partner[j]), a.ptr<float>(partner[j]) + kDim,
              b.ptr<float>(j));
    add_noise(b.ptr<float>(j), rng, 0.01f);
  }
  normalize_rows(b);
  const std::vector<std::pair<int, int>> expected = {
      {0, 1}, {2, 3}, {4, 2}, {5, 4}, {6, 0}};
  EXPECT_EQ(match_descriptors(a, b, kRatio, 1), expected);
  EXPECT_EQ(match_descriptors(a, b, kRatio, 4), expected);
}

// The rule written out plainly (each pair alone, with the header's
// quantized_dot for non-negative rows, else the exact dot product in
// double), against the blocked and vectorized scans, on rows whose counts
// leave tails everywhere and with exact ties in both directions.
std::vector<std::pair<int, int>> plain_matches(const cv::Mat& a,
                                               const cv::Mat& b, double ratio,
                                               bool quantized = true) {
  auto dot = [&](int i, int j) {
    if (quantized)
      return double{quantized_dot(a.ptr<float>(i), b.ptr<float>(j))};
    double sum = 0;
    for (int k = 0; k < kDim; ++k)
      sum += double{a.at<float>(i, k)} * b.at<float>(j, k);
    return sum;
  };
  std::vector<int> best_row(b.rows, -1);
  std::vector<double> best_dot(b.rows, -2);
  std::vector<std::pair<int, int>> matches;
  for (int i = 0; i < a.rows; ++i)
    for (int j = 0; j < b.rows; ++j)
      if (dot(i, j) > best_dot[j]) best_dot[j] = dot(i, j), best_row[j] = i;
  for (int i = 0; i < a.rows; ++i) {
    double first = -2, second = -2;
    int index = -1;
    for (int j = 0; j < b.rows; ++j) {
      const double d = dot(i, j);
      if (d > first) {
        second = first, first = d, index = j;
      } else if (d > second) {
        second = d;
      }
    }
    auto distance = [](double d) {
      return std::sqrt(std::max(0.0, 2 - 2 * d));
    };
    if (index < 0 || best_row[index] != i) continue;
    if (b.rows > 1 && distance(first) >= ratio * distance(second)) continue;
    matches.emplace_back(i, index);
  }
  return matches;
}

TEST(MatcherTest, AgreesWithThePlainRule) {
  MatchData data = make_match_data(8);
  cv::Mat b = data.b.rowRange(0, 701).clone();  // 701: an 8-column tail
  data.a.row(3).copyTo(b.row(700));  // b rows 700 and a partner: a tie
  for (int rows : {1, 3, 9, 701}) {
    const cv::Mat part = b.rowRange(0, rows);
    EXPECT_EQ(match_descriptors(data.a, part, kRatio, 2),
              plain_matches(data.a, part, kRatio))
        << rows << " rows in b";
    EXPECT_EQ(match_descriptors(part, data.a, kRatio, 1),
              plain_matches(part, data.a, kRatio))
        << rows << " rows in a";
  }
}

// The 12-bit rows stay within 2e-4 of the exact dot product on RootSIFT-like
// rows.
TEST(MatcherTest, QuantizedDotIsCloseToTheExactOne) {
  const MatchData data = make_match_data(9);
  double worst = 0;
  for (int i = 0; i < 50; ++i) {
    for (int j = 0; j < data.b.rows; j += 7) {
      double exact = 0;
      for (int k = 0; k < kDim; ++k)
        exact += double{data.a.at<float>(i, k)} * data.b.at<float>(j, k);
      const double coded =
          quantized_dot(data.a.ptr<float>(i), data.b.ptr<float>(j));
      worst = std::max(worst, std::abs(coded - exact));
    }
  }
  EXPECT_LT(worst, 2e-4);
  EXPECT_GT(worst, 0.0);  // it is an approximation: the rows are not 12-bit
  std::vector<float> negative(kDim, 0.1f);
  negative[3] = -0.1f;
  EXPECT_THROW(quantized_dot(negative.data(), data.b.ptr<float>(0)),
               std::invalid_argument);
}

// ARSCOUT_CPU_DISABLE rules kernels out, so that CTest can run this suite
// once per kernel on a machine with the newest one (tests/engine/CMakeLists:
// the "avx2." and "portable." copies).
TEST(MatcherTest, KernelFollowsCpuDisable) {
  const char* env = std::getenv("ARSCOUT_CPU_DISABLE");
  const std::string disabled = env ? env : "";
  const std::string kernel = matcher_kernel();
  RecordProperty("kernel", kernel);
  EXPECT_TRUE(kernel == "avx512vnni" || kernel == "avx2" ||
              kernel == "portable")
      << kernel;
  if (disabled.find("avx512vnni") != std::string::npos) {
    EXPECT_NE(kernel, "avx512vnni");
  }
  if (disabled.find("avx2") != std::string::npos) {
    EXPECT_EQ(kernel, "portable");
  }
}

// Rows with a negative component are matched by the exact dot product.
TEST(MatcherTest, RowsWithNegativeComponentsAreMatchedExactly) {
  MatchData data = make_match_data(10);
  for (int r = 0; r < data.a.rows; r += 2) data.a.at<float>(r, 0) *= -1;
  for (int r = 0; r < data.b.rows; r += 2) data.b.at<float>(r, 0) *= -1;
  EXPECT_EQ(match_descriptors(data.a, data.b, kRatio, 2),
            plain_matches(data.a, data.b, kRatio, /*quantized=*/false));
}

TEST(MatcherTest, EmptyInputsGiveNoMatches) {
  const MatchData data = make_match_data(6);
  EXPECT_TRUE(match_descriptors(cv::Mat(), data.b, kRatio, 1).empty());
  EXPECT_TRUE(match_descriptors(data.a, cv::Mat(), kRatio, 1).empty());
  EXPECT_TRUE(
      match_descriptors(cv::Mat(0, kDim, CV_32F), data.b, kRatio, 2).empty());
  EXPECT_TRUE(match_descriptors(cv::Mat(), cv::Mat(), kRatio, 1).empty());
}

TEST(MatcherTest, WrongLayoutThrows) {
  const MatchData data = make_match_data(7);
  cv::Mat doubles;
  data.a.convertTo(doubles, CV_64F);
  EXPECT_THROW(match_descriptors(doubles, data.b, kRatio, 1),
               std::invalid_argument);
  EXPECT_THROW(match_descriptors(data.a, doubles, kRatio, 1),
               std::invalid_argument);
  cv::Mat bytes;
  data.a.convertTo(bytes, CV_8U, 255);
  EXPECT_THROW(match_descriptors(bytes, bytes, kRatio, 1),
               std::invalid_argument);
  const cv::Mat narrow = data.a.colRange(0, 64).clone();  // 64 columns
  EXPECT_THROW(match_descriptors(narrow, narrow, kRatio, 1),
               std::invalid_argument);
}

}  // namespace
}  // namespace arscout::engine
