#include "features/matcher.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <stdexcept>
#include <string>

#if defined(__x86_64__)
#include <immintrin.h>
#endif

#include "runtime/parallel.h"

namespace arscout::engine {
namespace {

constexpr int kDim = 128;
constexpr int kRowBlock = 4;

struct RowBest {
  float first = -2, second = -2;  // dot products (higher is closer)
  int index = -1;
};

// Per b row, the best a row so far and its dot product (arrays apart, for
// the vector scan).
struct ColumnBests {
  explicit ColumnBests(int n) : value(n, -2.0f), row(n, -1) {}
  std::vector<float> value;
  std::vector<int> row;
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
// The four rows' dot products with one b row, summed as 8-lane partial
// sums over k and then a fixed tree of horizontal adds.
__attribute__((target("avx2,fma"))) inline __m128 reduce_four(__m256 s0,
                                                              __m256 s1,
                                                              __m256 s2,
                                                              __m256 s3) {
  const __m256 h =
      _mm256_hadd_ps(_mm256_hadd_ps(s0, s1), _mm256_hadd_ps(s2, s3));
  return _mm_add_ps(_mm256_castps256_ps128(h), _mm256_extractf128_ps(h, 1));
}

__attribute__((target("avx2,fma"))) inline void store_four(__m128 sums, int nb,
                                                           float* out) {
  float lanes[4];
  _mm_storeu_ps(lanes, sums);
  for (int r = 0; r < kRowBlock; ++r) out[r * nb] = lanes[r];
}

// The same with AVX2 and FMA: the matcher's whole cost is here. Two b rows
// at a time share each load of the four a rows (loads, not multiplies,
// bound this loop); every dot product is summed exactly as for one row
// alone, so the result does not depend on the pairing.
__attribute__((target("avx2,fma"))) void dot_block_avx2(const float* a,
                                                        const float* b, int nb,
                                                        float* out) {
  int j = 0;
  for (; j + 1 < nb; j += 2) {
    const float* bj = b + j * kDim;
    __m256 s0 = _mm256_setzero_ps(), s1 = s0, s2 = s0, s3 = s0;
    __m256 t0 = s0, t1 = s0, t2 = s0, t3 = s0;
    for (int k = 0; k < kDim; k += 8) {
      const __m256 v = _mm256_loadu_ps(bj + k);
      const __m256 w = _mm256_loadu_ps(bj + kDim + k);
      const __m256 a0 = _mm256_loadu_ps(a + k);
      const __m256 a1 = _mm256_loadu_ps(a + kDim + k);
      const __m256 a2 = _mm256_loadu_ps(a + 2 * kDim + k);
      const __m256 a3 = _mm256_loadu_ps(a + 3 * kDim + k);
      s0 = _mm256_fmadd_ps(a0, v, s0);
      s1 = _mm256_fmadd_ps(a1, v, s1);
      s2 = _mm256_fmadd_ps(a2, v, s2);
      s3 = _mm256_fmadd_ps(a3, v, s3);
      t0 = _mm256_fmadd_ps(a0, w, t0);
      t1 = _mm256_fmadd_ps(a1, w, t1);
      t2 = _mm256_fmadd_ps(a2, w, t2);
      t3 = _mm256_fmadd_ps(a3, w, t3);
    }
    store_four(reduce_four(s0, s1, s2, s3), nb, out + j);
    store_four(reduce_four(t0, t1, t2, t3), nb, out + j + 1);
  }
  for (; j < nb; ++j) {
    const float* bj = b + j * kDim;
    __m256 s0 = _mm256_setzero_ps(), s1 = s0, s2 = s0, s3 = s0;
    for (int k = 0; k < kDim; k += 8) {
      const __m256 v = _mm256_loadu_ps(bj + k);
      s0 = _mm256_fmadd_ps(_mm256_loadu_ps(a + k), v, s0);
      s1 = _mm256_fmadd_ps(_mm256_loadu_ps(a + kDim + k), v, s1);
      s2 = _mm256_fmadd_ps(_mm256_loadu_ps(a + 2 * kDim + k), v, s2);
      s3 = _mm256_fmadd_ps(_mm256_loadu_ps(a + 3 * kDim + k), v, s3);
    }
    store_four(reduce_four(s0, s1, s2, s3), nb, out + j);
  }
}

// ARSCOUT_CPU_DISABLE lists instruction sets the kernels must not use
// (comma separated, any case: "avx2", "avx512vnni"), as OpenCV's
// OPENCV_CPU_DISABLE does: a machine with the newest set can then test the
// older kernels, and a user can rule out a suspect one.
bool cpu_disabled(const std::string& feature) {
  const char* env = std::getenv("ARSCOUT_CPU_DISABLE");
  std::string list = env ? env : "";
  for (char& c : list)
    c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  size_t begin = 0;
  while (begin <= list.size()) {
    const size_t end = std::min(list.find(',', begin), list.size());
    if (list.compare(begin, end - begin, feature) == 0) return true;
    begin = end + 1;
  }
  return false;
}

bool cpu_has_avx2() {
  static const bool has = __builtin_cpu_supports("avx2") &&
                          __builtin_cpu_supports("fma") &&
                          !cpu_disabled("avx2");
  return has;
}
#endif

void dot_block(const float* a, const float* b, int nb, float* out) {
#if defined(__x86_64__)
  if (cpu_has_avx2()) return dot_block_avx2(a, b, nb, out);
#endif
  dot_block_portable(a, b, nb, out);
}

// One a row's dot products with b rows [from, nb): the row's two best,
// and per column the best row so far. Strictly better only, so that ties
// go to the lower index (of b for the row, of a for the column).
void scan_dots_portable(const float* dots, int from, int nb, int row,
                        RowBest& best, ColumnBests& columns) {
  for (int j = from; j < nb; ++j) {
    const float d = dots[j];
    if (d > best.first) {
      best.second = best.first;
      best.first = d;
      best.index = j;
    } else if (d > best.second) {
      best.second = d;
    }
    if (d > columns.value[j]) {
      columns.value[j] = d;
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

// scan_dots_portable eight columns at a time, with the same result: each
// lane keeps its own two best, merged at the end, then the tail.
__attribute__((target("avx2,fma"))) void scan_dots_avx2(const float* dots,
                                                        int nb, int row,
                                                        RowBest& best,
                                                        ColumnBests& columns) {
  __m256 first = _mm256_set1_ps(-2.0f), second = first;
  __m256 index = _mm256_castsi256_ps(_mm256_set1_epi32(-1));
  __m256i lane_j = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  const __m256 row_bits = _mm256_castsi256_ps(_mm256_set1_epi32(row));
  int j = 0;
  for (; j + 8 <= nb; j += 8) {
    const __m256 d = _mm256_loadu_ps(dots + j);
    const __m256 gt = _mm256_cmp_ps(d, first, _CMP_GT_OQ);
    second = _mm256_blendv_ps(_mm256_max_ps(second, d), first, gt);
    first = _mm256_blendv_ps(first, d, gt);
    index = _mm256_blendv_ps(index, _mm256_castsi256_ps(lane_j), gt);
    lane_j = _mm256_add_epi32(lane_j, _mm256_set1_epi32(8));
    float* value = columns.value.data() + j;
    float* rows = reinterpret_cast<float*>(columns.row.data() + j);
    const __m256 old = _mm256_loadu_ps(value);
    const __m256 better = _mm256_cmp_ps(d, old, _CMP_GT_OQ);
    _mm256_storeu_ps(value, _mm256_blendv_ps(old, d, better));
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
  scan_dots_portable(dots, j, nb, row, best, columns);
}
#endif

void scan_dots(const float* dots, int nb, int row, RowBest& best,
               ColumnBests& columns) {
#if defined(__x86_64__)
  if (cpu_has_avx2()) return scan_dots_avx2(dots, nb, row, best, columns);
#endif
  scan_dots_portable(dots, 0, nb, row, best, columns);
}

// Rows [begin, end) of a against all of b: each row's two best and, per
// column, the best row seen in this range.
void scan_rows(const cv::Mat& a, const cv::Mat& b, int begin, int end,
               std::vector<RowBest>& rows, ColumnBests& columns) {
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
    for (int r = 0; r < n; ++r)
      scan_dots(block.data() + static_cast<size_t>(r) * nb, nb, r0 + r,
                rows[r0 + r], columns);
  }
}

// --- 12-bit rows (quantized_dot in the header) ------------------------------
// A descriptor takes 256 bytes instead of 512, and one VNNI instruction
// multiplies and sums 16 components where an FMA does 8: the full match of
// two 3000-feature photos, the engine's largest cost per photo, gets
// cheaper. Integer sums are exact, so every kernel below gives the same
// bits. 7-bit rows were tried first: their dot products were up to 3e-3
// off, and across the two halves of a block walk the ratio test kept 10
// pairs instead of 16 and the halves no longer merged.

// 128 products of two codes stay within int32: 128 x 4095^2 < 2^31.
constexpr float kCodeMax = 4095;

struct QuantizedRows {
  std::vector<int16_t> codes;  // rows x kDim, zero rows padding the tail
  std::vector<float> scale;    // per row: its largest component / 4095
};

// std::lround for 0 <= x <= 4095 without its library call, which took
// about a twelfth of the matcher's time: x - floor(x) is exact for such x,
// so the codes are the same bits (checked for every float from 0 to 4095).
inline int16_t round_code(float x) {
  const int whole = static_cast<int>(x);
  return static_cast<int16_t>(whole + (x - static_cast<float>(whole) >= 0.5f));
}

// One row's codes and its scale (its largest component / 4095; 0 for a zero
// row); -1 when a component is negative.
float quantize_row(const float* row, int16_t* code) {
  float top = 0;
  for (int k = 0; k < kDim; ++k) {
    if (row[k] < 0) return -1;
    top = std::max(top, row[k]);
  }
  if (top <= 0) {
    std::fill(code, code + kDim, 0);
    return 0;
  }
  for (int k = 0; k < kDim; ++k)
    code[k] = round_code(row[k] * (kCodeMax / top));
  return top / kCodeMax;
}

// False when a row has a negative component: such rows are matched in
// float.
bool quantize_rows(const cv::Mat& m, QuantizedRows& q) {
  const int padded = (m.rows + kRowBlock - 1) / kRowBlock * kRowBlock;
  q.codes.assign(static_cast<size_t>(padded) * kDim, 0);
  q.scale.assign(padded, 0.0f);
  for (int r = 0; r < m.rows; ++r) {
    q.scale[r] = quantize_row(m.ptr<float>(r),
                              q.codes.data() + static_cast<size_t>(r) * kDim);
    if (q.scale[r] < 0) return false;
  }
  return true;
}

void code_dots_portable(const int16_t* a, const int16_t* b, int nb,
                        int32_t* out) {
  for (int j = 0; j < nb; ++j) {
    const int16_t* bj = b + static_cast<size_t>(j) * kDim;
    for (int r = 0; r < kRowBlock; ++r) {
      const int16_t* ar = a + r * kDim;
      int32_t sum = 0;
      for (int k = 0; k < kDim; ++k) sum += int32_t{ar[k]} * bj[k];
      out[r * nb + j] = sum;
    }
  }
}

#if defined(__x86_64__)
__attribute__((target("avx2"))) inline void store_code_sums(
    __m256i s0, __m256i s1, __m256i s2, __m256i s3, int nb, int32_t* out) {
  const __m256i h =
      _mm256_hadd_epi32(_mm256_hadd_epi32(s0, s1), _mm256_hadd_epi32(s2, s3));
  int32_t lanes[4];
  _mm_storeu_si128(
      reinterpret_cast<__m128i*>(lanes),
      _mm_add_epi32(_mm256_castsi256_si128(h), _mm256_extracti128_si256(h, 1)));
  for (int r = 0; r < kRowBlock; ++r) out[r * nb] = lanes[r];
}

__attribute__((target("avx2"))) inline __m256i load_code(const int16_t* p) {
  return _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p));
}

// Four a rows against each b row, 16 components a step: int16 products
// summed in pairs into int32.
__attribute__((target("avx2"))) void code_dots_avx2(const int16_t* a,
                                                    const int16_t* b, int nb,
                                                    int32_t* out) {
  for (int j = 0; j < nb; ++j) {
    const int16_t* bj = b + static_cast<size_t>(j) * kDim;
    __m256i s0 = _mm256_setzero_si256(), s1 = s0, s2 = s0, s3 = s0;
    for (int k = 0; k < kDim; k += 16) {
      const __m256i v = load_code(bj + k);
      s0 = _mm256_add_epi32(s0, _mm256_madd_epi16(load_code(a + k), v));
      s1 = _mm256_add_epi32(s1, _mm256_madd_epi16(load_code(a + kDim + k), v));
      s2 = _mm256_add_epi32(s2,
                            _mm256_madd_epi16(load_code(a + 2 * kDim + k), v));
      s3 = _mm256_add_epi32(s3,
                            _mm256_madd_epi16(load_code(a + 3 * kDim + k), v));
    }
    store_code_sums(s0, s1, s2, s3, nb, out + j);
  }
}

// The same with AVX-512 VNNI: one instruction multiplies, sums in pairs and
// accumulates.
__attribute__((target("avx2,avx512vnni,avx512vl"))) void code_dots_vnni(
    const int16_t* a, const int16_t* b, int nb, int32_t* out) {
  for (int j = 0; j < nb; ++j) {
    const int16_t* bj = b + static_cast<size_t>(j) * kDim;
    __m256i s0 = _mm256_setzero_si256(), s1 = s0, s2 = s0, s3 = s0;
    for (int k = 0; k < kDim; k += 16) {
      const __m256i v = load_code(bj + k);
      s0 = _mm256_dpwssd_epi32(s0, load_code(a + k), v);
      s1 = _mm256_dpwssd_epi32(s1, load_code(a + kDim + k), v);
      s2 = _mm256_dpwssd_epi32(s2, load_code(a + 2 * kDim + k), v);
      s3 = _mm256_dpwssd_epi32(s3, load_code(a + 3 * kDim + k), v);
    }
    store_code_sums(s0, s1, s2, s3, nb, out + j);
  }
}

bool cpu_has_vnni() {
  static const bool has =
      cpu_has_avx2() && __builtin_cpu_supports("avx512vnni") &&
      __builtin_cpu_supports("avx512vl") && !cpu_disabled("avx512vnni");
  return has;
}
#endif

void code_dots(const int16_t* a, const int16_t* b, int nb, int32_t* out) {
#if defined(__x86_64__)
  if (cpu_has_vnni()) return code_dots_vnni(a, b, nb, out);
  if (cpu_has_avx2()) return code_dots_avx2(a, b, nb, out);
#endif
  code_dots_portable(a, b, nb, out);
}

// Rows [begin, end) of a against all of b, as scan_rows, on 12-bit rows.
void scan_code_rows(const QuantizedRows& a, const QuantizedRows& b, int nb,
                    int begin, int end, std::vector<RowBest>& rows,
                    ColumnBests& columns) {
  std::vector<int32_t> sums(static_cast<size_t>(kRowBlock) * nb);
  std::vector<float> block(sums.size());
  for (int r0 = begin; r0 < end; r0 += kRowBlock) {
    const int n = std::min(kRowBlock, end - r0);
    code_dots(a.codes.data() + static_cast<size_t>(r0) * kDim, b.codes.data(),
              nb, sums.data());
    for (int r = 0; r < n; ++r) {
      const float sa = a.scale[r0 + r];
      const int32_t* in = sums.data() + static_cast<size_t>(r) * nb;
      float* out = block.data() + static_cast<size_t>(r) * nb;
      for (int j = 0; j < nb; ++j)
        out[j] = static_cast<float>(in[j]) * (sa * b.scale[j]);
      scan_dots(out, nb, r0 + r, rows[r0 + r], columns);
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
  std::vector<ColumnBests> columns(parts, ColumnBests(b.rows));
  // Parts start at multiples of the row block: the 12-bit rows are padded
  // only at the end.
  const int chunk =
      ((a.rows + parts - 1) / parts + kRowBlock - 1) / kRowBlock * kRowBlock;
  QuantizedRows qa, qb;
  const bool coded = quantize_rows(a, qa) && quantize_rows(b, qb);
  run_workers(parts, [&](int p) {
    const int begin = std::min(a.rows, p * chunk),
              end = std::min(a.rows, begin + chunk);
    if (coded)
      scan_code_rows(qa, qb, b.rows, begin, end, rows, columns[p]);
    else
      scan_rows(a, b, begin, end, rows, columns[p]);
  });
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
    if (b.rows > 1 && distance_from_dot(best.first) >=
                          ratio * distance_from_dot(best.second)) {
      continue;
    }
    matches.emplace_back(i, best.index);
  }
  return matches;
}

const char* matcher_kernel() {
#if defined(__x86_64__)
  if (cpu_has_vnni()) return "avx512vnni";
  if (cpu_has_avx2()) return "avx2";
#endif
  return "portable";
}

float quantized_dot(const float* a, const float* b) {
  int16_t code_a[kDim], code_b[kDim];
  const float scale_a = quantize_row(a, code_a);
  const float scale_b = quantize_row(b, code_b);
  if (scale_a < 0 || scale_b < 0)
    throw std::invalid_argument("quantized_dot: a component is negative");
  int32_t sum = 0;
  for (int k = 0; k < kDim; ++k) sum += int32_t{code_a[k]} * code_b[k];
  return static_cast<float>(sum) * (scale_a * scale_b);
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
