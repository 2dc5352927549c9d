// The plane sweep's per-row inner loops (plane_sweep.cpp runs them over
// image strips), vectorized four pixels at a time. Every `count` must be a
// multiple of kRowAlignment: callers pad their rows, and ignore what the
// padding computes.
#pragma once

#include <cstdint>

namespace arscout::engine::sweep_kernels {

constexpr int kRowAlignment = 4;
constexpr float kNoScore = -2;  // below any ZNCC
// A ray meets a plane in front of the camera when the dot of K^-T n with
// the pixel (x, y, 1) exceeds this (update_winner_row).
constexpr float kMinRayDot = 1e-6f;
// Grey levels are centred before the window sums, which keeps the float
// sums of squares small and accurate; ZNCC does not see the offset.
constexpr float kGreyCentre = 127.5f;
// Zero border around a neighbour's grey image, wide enough that every
// clamped sample position below reads inside the padded buffer.
constexpr int kGreyPad = 3;

// A neighbour's grey image with kGreyPad zero pixels on every side:
// pixel (x, y) is at pixels[(y + kGreyPad) * stride + x + kGreyPad].
struct PaddedGrey {
  const float* pixels = nullptr;
  int stride = 0;
  int cols = 0, rows = 0;  // of the image itself
};

// One row of warped samples: for each key column xs[i] on key row y, the
// neighbour grey through the homography h (row-major 3x3, key pixel to
// neighbour pixel), bilinear on cv::warpPerspective's 1/32-pixel grid with
// 0 outside the image and where the plane is behind the neighbour, less
// kGreyCentre. Writes b, b*b, a*b (a: the centred key grey) and inside:
// 1 where a window centred at the sample stays within the neighbour (the
// sample at least `margin` pixels from every border), else 0.
void warp_row(const float* h, float y, const float* xs, int count,
              const PaddedGrey& grey, float margin, const float* a, float* b,
              float* bb, float* ab, float* inside);

// out[i] = rows[0][i] + ... + rows[n - 1][i], i < count.
void sum_rows(const float* const* rows, int n, int count, float* out);
// sum[i] = (sum[i] + add[i]) - remove[i], i < count: a window sum moved
// on by one row.
void slide_rows(float* sum, const float* add, const float* remove, int count);
// out[i] = in[i] + in[i + 1] + ... + in[i + n - 1], i < count.
void sum_runs(const float* in, int n, int count, float* out);

// One row of ZNCC from the window sums of b, b^2 and a*b, folded into the
// running best, sum and count over neighbours. Pixels outside the
// neighbour (inside 0), without key texture (inverse_std_a 0) or with a
// flat warped window are left alone.
void zncc_row(const float* sum_b, const float* sum_bb, const float* sum_ab,
              const float* inside, const float* mean_a,
              const float* inverse_std_a, float inverse_n, int count,
              float* best, float* sum, float* hits);

// The aggregate over neighbours, into best: where any neighbour scored
// (hits > 0), the mean, or the best less `penalty` when that is higher.
void combine_row(const float* sum, const float* hits, float penalty, int count,
                 float* best);

// The winner-takes-all state of one row of key pixels.
struct WinnerRow {
  float* score;   // best aggregated score so far
  float* second;  // best score at a depth outside the winner's basin
  float* before;  // the winner's neighbour planes' scores, for the
  float* after;   // sub-plane refinement
  float* depth;
  int32_t* direction;
  int32_t* plane;
};

// One plane's scores (kNoScore: none) at depth d / ray_dot per pixel, for
// plane `plane` of direction `direction`; `previous` holds the plane
// before's scores. Depths within `basin` (relative) of the winner's do not
// count as a runner-up.
void update_winner_row(const float* scores, const float* previous,
                       const float* ray_dot, float d, float basin,
                       int32_t direction, int32_t plane, int count,
                       const WinnerRow& row);

}  // namespace arscout::engine::sweep_kernels
