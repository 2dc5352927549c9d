// The row loops in OpenCV's universal intrinsics (4 float lanes: SSE2 on
// x86-64, NEON on ARM, plain C++ elsewhere), written out rather than left
// to the auto-vectorizer, which gives up on their selects. Every lane does
// the same float operations in the same order, so results do not depend on
// where a pixel falls in a vector.
#include "dense/sweep_kernels.h"

#include <cassert>

#include <opencv2/core/hal/intrin.hpp>

namespace arscout::engine::sweep_kernels {
namespace {

using cv::v_float32x4;
using cv::v_int32x4;

constexpr int kLanes = 4;
constexpr float kSubpixels = 32;  // cv::warpPerspective's grid
constexpr int kSubpixelBits = 5;

v_float32x4 all(float v) { return cv::v_setall_f32(v); }
v_int32x4 all(int v) { return cv::v_setall_s32(v); }

}  // namespace

void warp_row(const float* h, float y, const float* xs, int count,
              const PaddedGrey& grey, float margin, const float* a, float* b,
              float* bb, float* ab, float* inside) {
  assert(count % kLanes == 0);
  const v_float32x4 h0 = all(h[0]), h3 = all(h[3]), h6 = all(h[6]);
  const v_float32x4 x_row = all(h[1] * y + h[2]), y_row = all(h[4] * y + h[5]),
                    w_row = all(h[7] * y + h[8]);
  const float margin_sub = kSubpixels * margin;
  const v_float32x4 min_pos = all(margin_sub);
  const v_float32x4 max_x = all(kSubpixels * (grey.cols - 1) - margin_sub);
  const v_float32x4 max_y = all(kSubpixels * (grey.rows - 1) - margin_sub);
  // Beyond these every tap is in the zero border: clamping there keeps the
  // reads inside the padded buffer and the sample 0.
  const float low = -2 * kSubpixels;
  const v_float32x4 v_low = all(low);
  const v_float32x4 high_x = all(kSubpixels * (grey.cols + 1));
  const v_float32x4 high_y = all(kSubpixels * (grey.rows + 1));
  // Truncating a positive number rounds half up on the 1/32 grid.
  const v_float32x4 to_positive = all(0.5f - low);
  const v_int32x4 back = all(static_cast<int>(low));
  const v_int32x4 fraction_mask = all((1 << kSubpixelBits) - 1);
  const v_int32x4 stride = all(grey.stride);
  const v_float32x4 one = all(1.0f), zero = all(0.0f), eps = all(1e-6f);
  const v_float32x4 subpixels = all(kSubpixels),
                    inverse_subpixels = all(1 / kSubpixels);
  const v_float32x4 centre = all(kGreyCentre);
  const float* origin = grey.pixels + kGreyPad * grey.stride + kGreyPad;
  for (int i = 0; i < count; i += kLanes) {
    const v_float32x4 x = cv::v_load(xs + i);
    const v_float32x4 w = h6 * x + w_row;
    const v_float32x4 in_front = w > eps;
    const v_float32x4 scale = cv::v_select(in_front, subpixels / w, zero);
    const v_float32x4 fx = (h0 * x + x_row) * scale;
    const v_float32x4 fy = (h3 * x + y_row) * scale;
    const v_float32x4 centred_inside = in_front & (fx >= min_pos) &
                                       (fy >= min_pos) & (fx <= max_x) &
                                       (fy <= max_y);
    const v_int32x4 X =
        cv::v_trunc(cv::v_min(cv::v_max(fx, v_low), high_x) + to_positive) +
        back;
    const v_int32x4 Y =
        cv::v_trunc(cv::v_min(cv::v_max(fy, v_low), high_y) + to_positive) +
        back;
    const v_float32x4 ax = cv::v_cvt_f32(X & fraction_mask) * inverse_subpixels;
    const v_float32x4 ay = cv::v_cvt_f32(Y & fraction_mask) * inverse_subpixels;
    const v_int32x4 offset =
        (Y >> kSubpixelBits) * stride + (X >> kSubpixelBits);
    v_float32x4 t00, t01, t10, t11;
    cv::v_lut_deinterleave(origin, offset, t00, t01);
    cv::v_lut_deinterleave(origin + grey.stride, offset, t10, t11);
    const v_float32x4 top = t00 * (one - ax) + t01 * ax;
    const v_float32x4 bottom = t10 * (one - ax) + t11 * ax;
    const v_float32x4 sample =
        cv::v_select(in_front, top * (one - ay) + bottom * ay, zero);
    const v_float32x4 centred = sample - centre;
    cv::v_store(b + i, centred);
    cv::v_store(bb + i, centred * centred);
    cv::v_store(ab + i, cv::v_load(a + i) * centred);
    cv::v_store(inside + i, one & centred_inside);
  }
}

// Summed in registers, each input read once: the window sums are a large
// share of the sweep's memory traffic.
void sum_rows(const float* const* rows, int n, int count, float* out) {
  assert(count % kLanes == 0);
  for (int i = 0; i < count; i += kLanes) {
    v_float32x4 sum = cv::v_load(rows[0] + i);
    for (int k = 1; k < n; ++k) sum += cv::v_load(rows[k] + i);
    cv::v_store(out + i, sum);
  }
}

void slide_rows(float* sum, const float* add, const float* remove, int count) {
  assert(count % kLanes == 0);
  for (int i = 0; i < count; i += kLanes) {
    cv::v_store(sum + i, (cv::v_load(sum + i) + cv::v_load(add + i)) -
                             cv::v_load(remove + i));
  }
}

void sum_runs(const float* in, int n, int count, float* out) {
  assert(count % kLanes == 0);
  int i = 0;
  // Four outputs at once: four independent chains of additions keep the
  // adder busy where one chain would wait on each addition's latency.
  for (; i + 4 * kLanes <= count; i += 4 * kLanes) {
    v_float32x4 s0 = cv::v_load(in + i), s1 = cv::v_load(in + i + kLanes),
                s2 = cv::v_load(in + i + 2 * kLanes),
                s3 = cv::v_load(in + i + 3 * kLanes);
    for (int k = 1; k < n; ++k) {
      s0 += cv::v_load(in + i + k);
      s1 += cv::v_load(in + i + kLanes + k);
      s2 += cv::v_load(in + i + 2 * kLanes + k);
      s3 += cv::v_load(in + i + 3 * kLanes + k);
    }
    cv::v_store(out + i, s0);
    cv::v_store(out + i + kLanes, s1);
    cv::v_store(out + i + 2 * kLanes, s2);
    cv::v_store(out + i + 3 * kLanes, s3);
  }
  for (; i < count; i += kLanes) {
    v_float32x4 sum = cv::v_load(in + i);
    for (int k = 1; k < n; ++k) sum += cv::v_load(in + i + k);
    cv::v_store(out + i, sum);
  }
}

void zncc_row(const float* sum_b, const float* sum_bb, const float* sum_ab,
              const float* inside, const float* mean_a,
              const float* inverse_std_a, float inverse_n, int count,
              float* best, float* sum, float* hits) {
  assert(count % kLanes == 0);
  const v_float32x4 n = all(inverse_n), zero = all(0.0f), one = all(1.0f),
                    flat = all(1e-3f), none = all(kNoScore);
  for (int i = 0; i < count; i += kLanes) {
    const v_float32x4 mean_b = cv::v_load(sum_b + i) * n;
    const v_float32x4 var_b = cv::v_load(sum_bb + i) * n - mean_b * mean_b;
    const v_float32x4 inv_a = cv::v_load(inverse_std_a + i);
    const v_float32x4 ok =
        (cv::v_load(inside + i) != zero) & (inv_a != zero) & (var_b > flat);
    const v_float32x4 zncc =
        (cv::v_load(sum_ab + i) * n - cv::v_load(mean_a + i) * mean_b) * inv_a /
        cv::v_sqrt(cv::v_select(ok, var_b, one));
    cv::v_store(best + i,
                cv::v_max(cv::v_load(best + i), cv::v_select(ok, zncc, none)));
    cv::v_store(sum + i, cv::v_load(sum + i) + (zncc & ok));
    cv::v_store(hits + i, cv::v_load(hits + i) + (one & ok));
  }
}

void combine_row(const float* sum, const float* hits, float penalty, int count,
                 float* best) {
  assert(count % kLanes == 0);
  const v_float32x4 zero = all(0.0f), one = all(1.0f), v_penalty = all(penalty);
  for (int i = 0; i < count; i += kLanes) {
    const v_float32x4 n = cv::v_load(hits + i);
    const v_float32x4 b = cv::v_load(best + i);
    const v_float32x4 mean = cv::v_load(sum + i) / cv::v_max(n, one);
    cv::v_store(best + i,
                cv::v_select(n > zero, cv::v_max(mean, b - v_penalty), b));
  }
}

void update_winner_row(const float* scores, const float* previous,
                       const float* ray_dot, float d, float basin,
                       int32_t direction, int32_t plane, int count,
                       const WinnerRow& row) {
  assert(count % kLanes == 0);
  const v_float32x4 none = all(kNoScore), zero = all(0.0f), one = all(1.0f),
                    eps = all(kMinRayDot), v_d = all(d), v_basin = all(basin);
  const v_int32x4 v_direction = all(direction), v_plane = all(plane),
                  v_before_plane = all(plane - 1);
  for (int i = 0; i < count; i += kLanes) {
    const v_float32x4 s = cv::v_load(scores + i);
    const v_float32x4 ray = cv::v_load(ray_dot + i);
    const v_int32x4 dir = cv::v_load(row.direction + i);
    const v_int32x4 index = cv::v_load(row.plane + i);
    const v_float32x4 best = cv::v_load(row.score + i);
    const v_float32x4 second = cv::v_load(row.second + i);
    const v_float32x4 depth = cv::v_load(row.depth + i);
    // The plane after the winner's: its score is the winner's "after".
    const v_float32x4 follows_winner = cv::v_reinterpret_as_f32(
        (dir == v_direction) & (index == v_before_plane));
    const v_float32x4 after =
        cv::v_select(follows_winner, s, cv::v_load(row.after + i));
    const v_float32x4 valid = (s > none) & (ray > eps);
    const v_float32x4 z = v_d / cv::v_select(valid, ray, one);
    const v_float32x4 same_basin =
        (depth > zero) & (cv::v_abs(z - depth) <= v_basin * depth);
    const v_float32x4 wins = valid & (s > best);
    const v_float32x4 runner_up = valid & ~same_basin & (s > second);
    const v_int32x4 wins_int = cv::v_reinterpret_as_s32(wins);
    cv::v_store(row.second + i,
                cv::v_select(wins, cv::v_select(same_basin, second, best),
                             cv::v_select(runner_up, s, second)));
    cv::v_store(row.before + i, cv::v_select(wins, cv::v_load(previous + i),
                                             cv::v_load(row.before + i)));
    cv::v_store(row.after + i, cv::v_select(wins, none, after));
    cv::v_store(row.score + i, cv::v_select(wins, s, best));
    cv::v_store(row.depth + i, cv::v_select(wins, z, depth));
    cv::v_store(row.direction + i, cv::v_select(wins_int, v_direction, dir));
    cv::v_store(row.plane + i, cv::v_select(wins_int, v_plane, index));
  }
}

}  // namespace arscout::engine::sweep_kernels
