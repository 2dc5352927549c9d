#include "matcher.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <thread>

#if defined(__x86_64__)
#include <immintrin.h>
#endif

namespace arscout::engine {
namespace {

constexpr int kDim = 128;
constexpr int kRowBlock = 4;

struct RowBest {
  float first = -2, second = -2;  // dot products (higher is closer)
  int index = -1;
};

struct ColumnBest {
  float value = -2;
  int row = -1;
};

// Dot products of four rows of a with every row of b, into out[4][nb].
// Descriptors are unit vectors, so the largest dot product is the nearest
// neighbour.
void dot_block_portable(const float* a, const float* b, int nb, float* out) {
  for (int j = 0; j < nb; ++j) {
    const float* bj = b + j * kDim;
    for (int r = 0; r < kRowBlock; ++r) {
      const float* ar = a + r * kDim;
      float sum = 0;
      for (int k = 0; k < kDim; ++k) sum += ar[k] * bj[k];
      out[r * nb + j] = sum;
    }
  }
}

#if defined(__x86_64__)
// The same with AVX2 and FMA: the matcher's whole cost is here.
__attribute__((target("avx2,fma"))) void dot_block_avx2(const float* a,
                                                        const float* b, int nb,
                                                        float* out) {
  for (int j = 0; j < nb; ++j) {
    const float* bj = b + j * kDim;
    __m256 s0 = _mm256_setzero_ps(), s1 = s0, s2 = s0, s3 = s0;
    for (int k = 0; k < kDim; k += 8) {
      const __m256 v = _mm256_loadu_ps(bj + k);
      s0 = _mm256_fmadd_ps(_mm256_loadu_ps(a + k), v, s0);
      s1 = _mm256_fmadd_ps(_mm256_loadu_ps(a + kDim + k), v, s1);
      s2 = _mm256_fmadd_ps(_mm256_loadu_ps(a + 2 * kDim + k), v, s2);
      s3 = _mm256_fmadd_ps(_mm256_loadu_ps(a + 3 * kDim + k), v, s3);
    }
    const __m256 h =
        _mm256_hadd_ps(_mm256_hadd_ps(s0, s1), _mm256_hadd_ps(s2, s3));
    const __m128 sums =
        _mm_add_ps(_mm256_castps256_ps128(h), _mm256_extractf128_ps(h, 1));
    float lanes[4];
    _mm_storeu_ps(lanes, sums);
    for (int r = 0; r < kRowBlock; ++r) out[r * nb + j] = lanes[r];
  }
}

bool cpu_has_avx2() {
  static const bool has =
      __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  return has;
}
#endif

void dot_block(const float* a, const float* b, int nb, float* out) {
#if defined(__x86_64__)
  if (cpu_has_avx2()) return dot_block_avx2(a, b, nb, out);
#endif
  dot_block_portable(a, b, nb, out);
}

// Rows [begin, end) of a against all of b: each row's two best and, per
// column, the best row seen in this range.
void scan_rows(const cv::Mat& a, const cv::Mat& b, int begin, int end,
               std::vector<RowBest>& rows, std::vector<ColumnBest>& columns) {
  const int nb = b.rows;
  std::vector<float> block(static_cast<size_t>(kRowBlock) * nb);
  float padded[kRowBlock * kDim];
  for (int r0 = begin; r0 < end; r0 += kRowBlock) {
    const int n = std::min(kRowBlock, end - r0);
    const float* a_rows = a.ptr<float>(r0);
    if (n < kRowBlock) {  // the tail: pad with zero rows
      std::fill(std::begin(padded), std::end(padded), 0.0f);
      std::copy(a_rows, a_rows + n * kDim, padded);
      a_rows = padded;
    }
    dot_block(a_rows, b.ptr<float>(0), nb, block.data());
    for (int r = 0; r < n; ++r) {
      RowBest& best = rows[r0 + r];
      const float* dots = block.data() + static_cast<size_t>(r) * nb;
      for (int j = 0; j < nb; ++j) {
        const float d = dots[j];
        if (d > best.first) {
          best.second = best.first;
          best.first = d;
          best.index = j;
        } else if (d > best.second) {
          best.second = d;
        }
        if (d > columns[j].value) columns[j] = {d, r0 + r};
      }
    }
  }
}

float distance_from_dot(float dot) {
  return std::sqrt(std::max(0.0f, 2.0f - 2.0f * dot));
}

}  // namespace

std::vector<std::pair<int, int>> match_descriptors(const cv::Mat& a,
                                                   const cv::Mat& b,
                                                   double ratio, int threads) {
  if (a.empty() || b.empty()) return {};
  if (a.type() != CV_32F || b.type() != CV_32F || a.cols != kDim ||
      b.cols != kDim || !a.isContinuous() || !b.isContinuous()) {
    throw std::invalid_argument("descriptors must be continuous CV_32F x 128");
  }
  std::vector<RowBest> rows(a.rows);
  const int parts = std::max(1, std::min(threads, a.rows / 256 + 1));
  std::vector<std::vector<ColumnBest>> columns(parts,
                                               std::vector<ColumnBest>(b.rows));
  std::vector<std::thread> workers;
  const int chunk = (a.rows + parts - 1) / parts;
  for (int p = 0; p < parts; ++p) {
    const int begin = p * chunk, end = std::min(a.rows, begin + chunk);
    auto work = [&, p, begin, end] {
      scan_rows(a, b, begin, end, rows, columns[p]);
    };
    if (p + 1 == parts)
      work();
    else
      workers.emplace_back(work);
  }
  for (std::thread& worker : workers) worker.join();
  // Merge the per-part column bests; parts are in row order, so keeping the
  // first strict maximum keeps the lower row on ties.
  std::vector<ColumnBest> best_column = columns[0];
  for (int p = 1; p < parts; ++p) {
    for (int j = 0; j < b.rows; ++j) {
      if (columns[p][j].value > best_column[j].value)
        best_column[j] = columns[p][j];
    }
  }
  std::vector<std::pair<int, int>> matches;
  for (int i = 0; i < a.rows; ++i) {
    const RowBest& best = rows[i];
    if (best.index < 0 || best_column[best.index].row != i) continue;
    if (b.rows > 1 && distance_from_dot(best.first) >=
                          ratio * distance_from_dot(best.second)) {
      continue;
    }
    matches.emplace_back(i, best.index);
  }
  return matches;
}

cv::Mat rotate_descriptors(const cv::Mat& descriptors, int quarter_turns) {
  const int turns = ((quarter_turns % 4) + 4) % 4;
  if (turns == 0) return descriptors;
  cv::Mat rotated(descriptors.size(), descriptors.type());
  for (int r = 0; r < descriptors.rows; ++r) {
    const float* in = descriptors.ptr<float>(r);
    float* out = rotated.ptr<float>(r);
    for (int row = 0; row < 4; ++row) {
      for (int col = 0; col < 4; ++col) {
        // Undoing a clockwise quarter turn moves cell (row, col) to
        // (3 - col, row) and turns every gradient by two of the eight bins.
        int new_row = row, new_col = col;
        for (int t = 0; t < turns; ++t) {
          const int previous_row = new_row;
          new_row = 3 - new_col;
          new_col = previous_row;
        }
        for (int bin = 0; bin < 8; ++bin) {
          out[(new_row * 4 + new_col) * 8 + (bin + 2 * turns) % 8] =
              in[(row * 4 + col) * 8 + bin];
        }
      }
    }
  }
  return rotated;
}

int overlap_score(const cv::Mat& a, const cv::Mat& b, double ratio,
                  int samples) {
  if (a.rows == 0 || b.rows < 2) return 0;
  const int n = std::min(samples, a.rows);
  cv::Mat sample(n, a.cols, a.type());
  for (int i = 0; i < n; ++i) {
    a.row(static_cast<int>(static_cast<int64_t>(i) * a.rows / n))
        .copyTo(sample.row(i));
  }
  return static_cast<int>(match_descriptors(sample, b, ratio, 1).size());
}

}  // namespace arscout::engine
