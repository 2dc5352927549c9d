#include "features/matcher.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <thread>
#include <vector>

#if defined(__x86_64__)
#include <immintrin.h>
#endif

namespace arscout::engine {
namespace {

constexpr int kDim = 128;
constexpr int kRowBlock = 4;

// Descriptors are compared as 16-bit integers: value v becomes
// round(v * kLevels), clamped to [0, kLevels] (a unit row's values never
// exceed 1). The integer dot products are exact and the same on every CPU,
// and so are the scores below (they stay under 2^24, exact as floats).
// Steps of 1/2048 keep the matches of floats; bytes (steps of 1/254 to
// 1/600, clamped at 127 steps) changed them enough to lose registrations
// on the Middlebury temple and on lund's phone photos (bench/RESULTS.md).
constexpr float kLevels = 2048.0f;
constexpr int kMaxLevel = 2048;
using Level = int16_t;

// Rows of `m` as levels, kDim per row, contiguous.
std::vector<Level> quantize(const cv::Mat& m) {
  std::vector<Level> levels(static_cast<size_t>(m.rows) * kDim);
  for (int r = 0; r < m.rows; ++r) {
    const float* row = m.ptr<float>(r);
    Level* out = levels.data() + static_cast<size_t>(r) * kDim;
    for (int k = 0; k < kDim; ++k) {
      // Rounds half up, as std::lround does for these non-negative values
      // (NaN counts as 0), at a fraction of its cost: lround was a library
      // call per value, and a photo's screens quantize millions of them.
      const float v = row[k] > 0 ? std::min(row[k], kMaxLevel / kLevels) : 0;
      // NOLINTNEXTLINE(bugprone-incorrect-roundings): v >= 0 here.
      out[k] = static_cast<Level>(v * kLevels + 0.5f);
    }
  }
  return levels;
}

// Squared norms of level rows. Levels round each value, so a row's norm is
// not exactly that of a unit row: distances are taken with the norms,
// |a - b|^2 = |a|^2 + |b|^2 - 2 a.b, never as 2 - 2 a.b.
std::vector<float> squared_norms(const std::vector<Level>& levels) {
  std::vector<float> norms(levels.size() / kDim);
  for (size_t r = 0; r < norms.size(); ++r) {
    int32_t sum = 0;
    for (int k = 0; k < kDim; ++k)
      sum += int32_t{levels[r * kDim + k]} * levels[r * kDim + k];
    norms[r] = static_cast<float>(sum);
  }
  return norms;
}

constexpr float kLowest = std::numeric_limits<float>::lowest();

// Scores of an a row i against the b rows: s_ij = 2 a_i.b_j - |b_j|^2 =
// |a_i|^2 - |a_i - b_j|^2, so the highest is the nearest b row; and per b
// row j, s_ij - |a_i|^2 = -|a_i - b_j|^2, highest for the nearest a row.
// All are integers below 2^24, exact as floats.
struct RowBest {
  float first = kLowest, second = kLowest;  // scores (higher is closer)
  int index = -1;
};

// Per b row, the best a row so far and its -|a_i - b_j|^2 (arrays apart,
// for the vector scan).
struct ColumnBests {
  explicit ColumnBests(int n) : value(n, kLowest), row(n, -1) {}
  std::vector<float> value;
  std::vector<int> row;
};

// Dot products of four level rows of a with every level row of b, into
// out[4][nb], as floats (exact: they stay below 2^24). Descriptors are unit
// vectors, so the largest dot product is the nearest neighbour.
void dot_block_portable(const Level* a, const Level* b, int nb, float* out) {
  for (int j = 0; j < nb; ++j) {
    const Level* bj = b + static_cast<size_t>(j) * kDim;
    for (int r = 0; r < kRowBlock; ++r) {
      const Level* ar = a + r * kDim;
      int32_t sum = 0;
      for (int k = 0; k < kDim; ++k) sum += int32_t{ar[k]} * bj[k];
      out[r * nb + j] = static_cast<float>(sum);
    }
  }
}

#if defined(__x86_64__)
// The four rows' 8-lane sums with one b row, as one float per row.
__attribute__((target("avx2,fma"))) inline __m128 reduce_four(__m256i s0,
                                                              __m256i s1,
                                                              __m256i s2,
                                                              __m256i s3) {
  const __m256i h =
      _mm256_hadd_epi32(_mm256_hadd_epi32(s0, s1), _mm256_hadd_epi32(s2, s3));
  return _mm_cvtepi32_ps(
      _mm_add_epi32(_mm256_castsi256_si128(h), _mm256_extracti128_si256(h, 1)));
}

__attribute__((target("avx2,fma"))) inline void store_four(__m128 sums, int nb,
                                                           float* out) {
  float lanes[4];
  _mm_storeu_ps(lanes, sums);
  for (int r = 0; r < kRowBlock; ++r) out[r * nb] = lanes[r];
}

// One 16-value step of a dot product: products summed in pairs (32 bits,
// exact), added to `sum`.
__attribute__((target("avx2,fma"))) inline __m256i add_products(__m256i sum,
                                                                __m256i a,
                                                                __m256i b) {
  return _mm256_add_epi32(sum, _mm256_madd_epi16(a, b));
}

__attribute__((target("avx2,fma"))) inline __m256i load16(const Level* p) {
  return _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p));
}

// The same with AVX2: the matcher's whole cost is here. Two b rows at a
// time share each load of the four a rows; integer sums make the result
// independent of the pairing and of the order of the additions.
__attribute__((target("avx2,fma"))) void dot_block_avx2(const Level* a,
                                                        const Level* b, int nb,
                                                        float* out) {
  int j = 0;
  for (; j + 1 < nb; j += 2) {
    const Level* bj = b + static_cast<size_t>(j) * kDim;
    __m256i s0 = _mm256_setzero_si256(), s1 = s0, s2 = s0, s3 = s0;
    __m256i t0 = s0, t1 = s0, t2 = s0, t3 = s0;
    for (int k = 0; k < kDim; k += 16) {
      const __m256i v = load16(bj + k), w = load16(bj + kDim + k);
      const __m256i a0 = load16(a + k), a1 = load16(a + kDim + k);
      const __m256i a2 = load16(a + 2 * kDim + k);
      const __m256i a3 = load16(a + 3 * kDim + k);
      s0 = add_products(s0, a0, v);
      s1 = add_products(s1, a1, v);
      s2 = add_products(s2, a2, v);
      s3 = add_products(s3, a3, v);
      t0 = add_products(t0, a0, w);
      t1 = add_products(t1, a1, w);
      t2 = add_products(t2, a2, w);
      t3 = add_products(t3, a3, w);
    }
    store_four(reduce_four(s0, s1, s2, s3), nb, out + j);
    store_four(reduce_four(t0, t1, t2, t3), nb, out + j + 1);
  }
  for (; j < nb; ++j) {
    const Level* bj = b + static_cast<size_t>(j) * kDim;
    __m256i s0 = _mm256_setzero_si256(), s1 = s0, s2 = s0, s3 = s0;
    for (int k = 0; k < kDim; k += 16) {
      const __m256i v = load16(bj + k);
      s0 = add_products(s0, load16(a + k), v);
      s1 = add_products(s1, load16(a + kDim + k), v);
      s2 = add_products(s2, load16(a + 2 * kDim + k), v);
      s3 = add_products(s3, load16(a + 3 * kDim + k), v);
    }
    store_four(reduce_four(s0, s1, s2, s3), nb, out + j);
  }
}

bool cpu_has_avx2() {
  static const bool has =
      __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  return has;
}
#endif

void dot_block(const Level* a, const Level* b, int nb, float* out) {
#if defined(__x86_64__)
  if (cpu_has_avx2()) return dot_block_avx2(a, b, nb, out);
#endif
  dot_block_portable(a, b, nb, out);
}

// One a row's scores against b rows [from, nb): the row's two best, and
// per column the best row so far (`row_norm` is the row's |a_i|^2).
// Strictly better only, so that ties go to the lower index (of b for the
// row, of a for the column).
void scan_scores_portable(const float* scores, int from, int nb, int row,
                          float row_norm, RowBest& best, ColumnBests& columns) {
  for (int j = from; j < nb; ++j) {
    const float d = scores[j];
    if (d > best.first) {
      best.second = best.first;
      best.first = d;
      best.index = j;
    } else if (d > best.second) {
      best.second = d;
    }
    if (d - row_norm > columns.value[j]) {
      columns.value[j] = d - row_norm;
      columns.row[j] = row;
    }
  }
}

#if defined(__x86_64__)
// The two best of eight lanes, each of which kept its own two best and the
// first index of its best: the best of all (the lowest index on ties) and,
// as second, the best of what remains (all seconds, the other lanes'
// bests).
void merge_lanes(const float* first, const float* second, const int* index,
                 RowBest& best) {
  int chosen = -1;
  for (int l = 0; l < 8; ++l) {
    if (index[l] < 0) continue;
    if (chosen < 0 || first[l] > first[chosen] ||
        (first[l] == first[chosen] && index[l] < index[chosen]))
      chosen = l;
  }
  if (chosen < 0) return;
  best.first = first[chosen];
  best.index = index[chosen];
  for (int l = 0; l < 8; ++l) {
    if (index[l] < 0) continue;
    best.second = std::max(best.second, second[l]);
    if (l != chosen) best.second = std::max(best.second, first[l]);
  }
}

// scan_scores_portable eight columns at a time, with the same result: each
// lane keeps its own two best, merged at the end, then the tail.
__attribute__((target("avx2,fma"))) void scan_scores_avx2(
    const float* scores, int nb, int row, float row_norm, RowBest& best,
    ColumnBests& columns) {
  __m256 first = _mm256_set1_ps(kLowest), second = first;
  const __m256 norm = _mm256_set1_ps(row_norm);
  __m256 index = _mm256_castsi256_ps(_mm256_set1_epi32(-1));
  __m256i lane_j = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  const __m256 row_bits = _mm256_castsi256_ps(_mm256_set1_epi32(row));
  int j = 0;
  for (; j + 8 <= nb; j += 8) {
    const __m256 d = _mm256_loadu_ps(scores + j);
    const __m256 gt = _mm256_cmp_ps(d, first, _CMP_GT_OQ);
    second = _mm256_blendv_ps(_mm256_max_ps(second, d), first, gt);
    first = _mm256_blendv_ps(first, d, gt);
    index = _mm256_blendv_ps(index, _mm256_castsi256_ps(lane_j), gt);
    lane_j = _mm256_add_epi32(lane_j, _mm256_set1_epi32(8));
    float* value = columns.value.data() + j;
    float* rows = reinterpret_cast<float*>(columns.row.data() + j);
    const __m256 old = _mm256_loadu_ps(value);
    const __m256 column_d = _mm256_sub_ps(d, norm);
    const __m256 better = _mm256_cmp_ps(column_d, old, _CMP_GT_OQ);
    _mm256_storeu_ps(value, _mm256_blendv_ps(old, column_d, better));
    _mm256_storeu_ps(rows,
                     _mm256_blendv_ps(_mm256_loadu_ps(rows), row_bits, better));
  }
  float lane_first[8], lane_second[8];
  int lane_index[8];
  _mm256_storeu_ps(lane_first, first);
  _mm256_storeu_ps(lane_second, second);
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(lane_index),
                      _mm256_castps_si256(index));
  merge_lanes(lane_first, lane_second, lane_index, best);
  scan_scores_portable(scores, j, nb, row, row_norm, best, columns);
}
#endif

void scan_scores(const float* scores, int nb, int row, float row_norm,
                 RowBest& best, ColumnBests& columns) {
#if defined(__x86_64__)
  if (cpu_has_avx2())
    return scan_scores_avx2(scores, nb, row, row_norm, best, columns);
#endif
  scan_scores_portable(scores, 0, nb, row, row_norm, best, columns);
}

// Level rows and their squared norms.
struct QuantizedRows {
  explicit QuantizedRows(const cv::Mat& m)
      : levels(quantize(m)), norms(squared_norms(levels)) {}
  std::vector<Level> levels;
  std::vector<float> norms;
  int size() const { return static_cast<int>(norms.size()); }
};

// Rows [begin, end) of a against all of b: each row's two best and, per
// column, the best row seen in this range.
void scan_rows(const QuantizedRows& a, const QuantizedRows& b, int begin,
               int end, std::vector<RowBest>& rows, ColumnBests& columns) {
  const int nb = b.size();
  std::vector<float> block(static_cast<size_t>(kRowBlock) * nb);
  Level padded[kRowBlock * kDim];
  for (int r0 = begin; r0 < end; r0 += kRowBlock) {
    const int n = std::min(kRowBlock, end - r0);
    const Level* a_rows = a.levels.data() + static_cast<size_t>(r0) * kDim;
    if (n < kRowBlock) {  // the tail: pad with zero rows
      std::fill(std::begin(padded), std::end(padded), Level{0});
      std::copy(a_rows, a_rows + n * kDim, padded);
      a_rows = padded;
    }
    dot_block(a_rows, b.levels.data(), nb, block.data());
    for (int r = 0; r < n; ++r) {
      float* scores = block.data() + static_cast<size_t>(r) * nb;
      for (int j = 0; j < nb; ++j) scores[j] = 2 * scores[j] - b.norms[j];
      scan_scores(scores, nb, r0 + r, a.norms[r0 + r], rows[r0 + r], columns);
    }
  }
}

// The distance of the row with squared norm `row_norm` from the b row it
// scored `score` against, in units of the descriptors.
float distance_from_score(float row_norm, float score) {
  return std::sqrt(std::max(0.0f, row_norm - score)) / kLevels;
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
  const QuantizedRows a_rows(a), b_rows(b);
  std::vector<RowBest> rows(a.rows);
  const int parts = std::max(1, std::min(threads, a.rows / 256 + 1));
  std::vector<ColumnBests> columns(parts, ColumnBests(b.rows));
  std::vector<std::thread> workers;
  const int chunk = (a.rows + parts - 1) / parts;
  for (int p = 0; p < parts; ++p) {
    const int begin = p * chunk, end = std::min(a.rows, begin + chunk);
    auto work = [&, p, begin, end] {
      scan_rows(a_rows, b_rows, begin, end, rows, columns[p]);
    };
    if (p + 1 == parts)
      work();
    else
      workers.emplace_back(work);
  }
  for (std::thread& worker : workers) worker.join();
  // Merge the per-part column bests; parts are in row order, so keeping the
  // first strict maximum keeps the lower row on ties.
  ColumnBests best_column = columns[0];
  for (int p = 1; p < parts; ++p) {
    for (int j = 0; j < b.rows; ++j) {
      if (columns[p].value[j] > best_column.value[j]) {
        best_column.value[j] = columns[p].value[j];
        best_column.row[j] = columns[p].row[j];
      }
    }
  }
  std::vector<std::pair<int, int>> matches;
  for (int i = 0; i < a.rows; ++i) {
    const RowBest& best = rows[i];
    if (best.index < 0 || best_column.row[best.index] != i) continue;
    const float norm = a_rows.norms[i];
    if (b.rows > 1 && distance_from_score(norm, best.first) >=
                          ratio * distance_from_score(norm, best.second)) {
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
