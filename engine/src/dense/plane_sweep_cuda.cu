// The CUDA plane sweep (built with -DARSCOUT_CUDA=ON): the CPU strip sweep
// of plane_sweep.cpp, pixel for pixel, on the whole key view at once.
//
// The host prepares what the CPU path computes once per sweep (greys by
// cv::cvtColor, the key's texture test by cv::boxFilter, every plane's
// homographies and bookkeeping constants), then two kernels run per plane:
// warp_kernel resamples each neighbour into the key view exactly as
// cv::warpPerspective does (INTER_LINEAR with its 1/32-pixel coordinate
// grid, 0 outside), and score_kernel sums each ZNCC window directly (with
// BORDER_REFLECT indices, as the CPU box filters), aggregates over the
// neighbours and updates the winner-takes-all state; finish_kernel then
// applies the rejection rules and the sub-plane refinement.
//
// The per-pixel work lives in __host__ __device__ functions so that it can
// be checked against the CPU path on a machine without a GPU.
#define EIGEN_NO_CUDA  // Eigen is host-only here: no __device__ annotations

#include <cuda_runtime.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstddef>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include <Eigen/Dense>

#include "dense/plane_sweep_cuda.h"
#include "dense/sweep_setup.h"

namespace arscout::engine::cuda {
namespace {

constexpr float kNoScore = -2;  // below any ZNCC, as in plane_sweep.cpp
// cv::warpPerspective resolves sample positions to 1/32 pixel.
constexpr int kInterBits = 5;
constexpr int kInterTab = 1 << kInterBits;
constexpr int kBlockX = 32, kBlockY = 8;

void check(cudaError_t status, const char* what) {
  if (status != cudaSuccess) {
    throw std::runtime_error(std::string("CUDA plane sweep: ") + what + ": " +
                             cudaGetErrorString(status));
  }
}

// A sweep direction as the kernels need it.
struct Direction {
  double nx = 0, ny = 0, nz = 0;  // K^-T normal: its dot with (x, y, 1)
  double d_near = 1, d_far = 10;
  int planes = 0;
};

// One plane of one direction.
struct PlaneArgs {
  int direction = 0;        // f
  int index = 0;            // i, within the direction
  size_t homographies = 0;  // offset of neighbour 0's H in the H array
  float d = 0;              // 1 / inverse offset, as update_winner uses it
  float basin = 0;          // relative depth band of the winner's basin
  double nx = 0, ny = 0, nz = 0;
};

// Everything the kernels read and write: device pointers, all images
// row-major width x height, neighbours one after another.
struct Buffers {
  int width = 0, height = 0, neighbours = 0, window = 0;
  double validity_margin = 0;  // window / 2 + 1, as the CPU path
  float penalty = 0;           // occlusion_penalty
  double min_score = 0, min_margin = 0;
  const float* key = nullptr;            // key grey
  const float* inverse_std = nullptr;    // 0: too little texture
  const float* grays = nullptr;          // neighbour greys
  const double* homographies = nullptr;  // 9 per neighbour per plane
  const Direction* directions = nullptr;
  float* warped = nullptr;    // each neighbour warped into the key view
  float* previous = nullptr;  // the previous plane's aggregated score
  float *best = nullptr, *second = nullptr, *before = nullptr, *after = nullptr,
        *depth = nullptr;
  int *direction = nullptr, *plane = nullptr;
  float *out_depth = nullptr, *out_score = nullptr, *out_margin = nullptr;
};

__host__ __device__ inline double inverse_offset(const Direction& d,
                                                 double plane) {
  const double step =
      d.planes > 1 ? (1 / d.d_far - 1 / d.d_near) / (d.planes - 1) : 0;
  return 1 / d.d_near + plane * step;
}

// std::max's choice (the first unless the second is larger).
__host__ __device__ inline float larger(float a, float b) {
  return a < b ? b : a;
}

// cv::BORDER_REFLECT: fedcba|abcdefgh|hgfedcb.
__host__ __device__ inline int reflect(int p, int n) {
  if (n == 1) return 0;
  while (p < 0 || p >= n) p = p < 0 ? -p - 1 : 2 * n - p - 1;
  return p;
}

// cvRound: to nearest, ties to even.
__host__ __device__ inline int round_to_int(double v) {
#ifdef __CUDA_ARCH__
  return __double2int_rn(v);
#else
  return static_cast<int>(std::lrint(v));
#endif
}

// The neighbour grey at key pixel (x, y) through H, as cv::warpPerspective
// with INTER_LINEAR | WARP_INVERSE_MAP and BORDER_CONSTANT 0 computes it:
// the position rounded to 1/32 pixel, bilinear weights from that grid.
__host__ __device__ inline float warp_pixel(const float* gray, int width,
                                            int height, const double* H, int x,
                                            int y) {
  const double X0 = H[0] * x + H[1] * y + H[2];
  const double Y0 = H[3] * x + H[4] * y + H[5];
  double W = H[6] * x + H[7] * y + H[8];
  W = W != 0 ? kInterTab / W : 0;
  const double lo = INT_MIN, hi = INT_MAX;
  double fx = X0 * W, fy = Y0 * W;
  fx = fx < lo ? lo : (fx > hi ? hi : fx);
  fy = fy < lo ? lo : (fy > hi ? hi : fy);
  const int X = round_to_int(fx), Y = round_to_int(fy);
  const int ix = X >> kInterBits, iy = Y >> kInterBits;  // floor
  const float ax = static_cast<float>(X & (kInterTab - 1)) / kInterTab;
  const float ay = static_cast<float>(Y & (kInterTab - 1)) / kInterTab;
  float taps[4];
  for (int k = 0; k < 4; ++k) {
    const int px = ix + (k & 1), py = iy + (k >> 1);
    taps[k] = px >= 0 && py >= 0 && px < width && py < height
                  ? gray[static_cast<size_t>(py) * width + px]
                  : 0.0f;
  }
  // Grey levels are whole numbers and the weights multiples of 1/1024, so
  // this is exact whatever the order of the sums.
  return taps[0] * ((1 - ay) * (1 - ax)) + taps[1] * ((1 - ay) * ax) +
         taps[2] * (ay * (1 - ax)) + taps[3] * (ay * ax);
}

// One neighbour's ZNCC at key pixel (x, y) for the plane with homography H,
// or kNoScore where the CPU path does not score it (the window reaches
// outside the neighbour, or the warped window is flat). The window sums
// are taken about the centre values, which keeps float sums accurate.
__host__ __device__ inline float zncc_pixel(const Buffers& b, const double* H,
                                            const float* warped, int x, int y,
                                            float inverse_std_a) {
  const double w = H[6] * x + H[7] * y + H[8];
  if (w <= 0) return kNoScore;
  const double u = (H[0] * x + H[1] * y + H[2]) / w;
  const double v = (H[3] * x + H[4] * y + H[5]) / w;
  const double margin = b.validity_margin;
  if (u < margin || v < margin || u > b.width - 1 - margin ||
      v > b.height - 1 - margin)
    return kNoScore;
  const int p = y * b.width + x;
  const float ca = b.key[p], cb = warped[p];
  const int r = b.window / 2;
  float sa = 0, sb = 0, sbb = 0, sab = 0;
  for (int dy = -r; dy <= r; ++dy) {
    const int row = reflect(y + dy, b.height) * b.width;
    for (int dx = -r; dx <= r; ++dx) {
      const int q = row + reflect(x + dx, b.width);
      const float da = b.key[q] - ca, db = warped[q] - cb;
      sa += da;
      sb += db;
      sbb += db * db;
      sab += da * db;
    }
  }
  const float n = static_cast<float>(b.window * b.window);
  const float mean_a = sa / n, mean_b = sb / n;
  const float var_b = sbb / n - mean_b * mean_b;
  if (var_b <= 1e-3f) return kNoScore;
  return (sab / n - mean_a * mean_b) * inverse_std_a / sqrtf(var_b);
}

// score_plane, combine_neighbours and update_winner of the CPU path for
// one pixel; warped holds this plane's warps.
__host__ __device__ inline void score_pixel(const Buffers& b,
                                            const PlaneArgs& plane, int x,
                                            int y) {
  const int p = y * b.width + x;
  const size_t image = static_cast<size_t>(b.width) * b.height;
  float score = kNoScore;
  const float inverse_std_a = b.inverse_std[p];
  if (inverse_std_a != 0) {
    float sum = 0, count = 0;
    for (int j = 0; j < b.neighbours; ++j) {
      const float zncc =
          zncc_pixel(b, b.homographies + plane.homographies + 9 * j,
                     b.warped + j * image, x, y, inverse_std_a);
      if (zncc <= kNoScore) continue;
      score = larger(score, zncc);
      sum += zncc;
      count += 1;
    }
    if (b.neighbours > 1 && count > 0)
      score = larger(sum / count, score - b.penalty);
  }
  const float previous = plane.index == 0 ? kNoScore : b.previous[p];
  b.previous[p] = score;

  const float ray = static_cast<float>(plane.nx * x + plane.ny * y + plane.nz);
  if (b.direction[p] == plane.direction && b.plane[p] == plane.index - 1)
    b.after[p] = score;
  if (score <= kNoScore || ray <= 1e-6f) return;
  const float z = plane.d / ray;
  const float depth = b.depth[p];
  const bool same_basin = depth > 0 && fabsf(z - depth) <= plane.basin * depth;
  if (score > b.best[p]) {
    if (!same_basin) b.second[p] = b.best[p];
    b.best[p] = score;
    b.depth[p] = z;
    b.direction[p] = plane.direction;
    b.plane[p] = plane.index;
    b.before[p] = previous;
    b.after[p] = kNoScore;
  } else if (!same_basin && score > b.second[p]) {
    b.second[p] = score;
  }
}

// StripSweep::finish for one pixel: outputs start zeroed.
__host__ __device__ inline void finish_pixel(const Buffers& b, int x, int y) {
  const int p = y * b.width + x;
  const int f = b.direction[p];
  if (f < 0) return;
  const Direction dir = b.directions[f];
  const int plane = b.plane[p];
  const float best = b.best[p], before = b.before[p], after = b.after[p];
  const float second = b.second[p];
  const float margin = best - larger(second, -1.0f);
  b.out_score[p] = best;
  b.out_margin[p] = margin;
  if (plane == 0 || plane == dir.planes - 1 || before <= kNoScore ||
      after <= kNoScore || best < b.min_score || margin < b.min_margin)
    return;
  const double curvature = before - 2.0 * best + after;
  double shift = 0;
  if (curvature < 0) {
    shift = 0.5 * (before - after) / curvature;
    shift = shift < -0.5 ? -0.5 : (shift > 0.5 ? 0.5 : shift);
  }
  const double d = 1 / inverse_offset(dir, plane + shift);
  const double ray_dot = dir.nx * x + dir.ny * y + dir.nz;
  b.out_depth[p] = static_cast<float>(d / ray_dot);
}

__host__ __device__ inline void init_pixel(const Buffers& b, int x, int y) {
  const int p = y * b.width + x;
  b.previous[p] = kNoScore;
  b.best[p] = kNoScore;
  b.second[p] = kNoScore;
  b.before[p] = kNoScore;
  b.after[p] = kNoScore;
  b.depth[p] = 0;
  b.direction[p] = -1;
  b.plane[p] = -1;
  b.out_depth[p] = 0;
  b.out_score[p] = 0;
  b.out_margin[p] = 0;
}

__global__ void init_kernel(Buffers b) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x;
  const int y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x < b.width && y < b.height) init_pixel(b, x, y);
}

// One thread per key pixel and neighbour (blockIdx.z).
__global__ void warp_kernel(Buffers b, size_t homographies) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x;
  const int y = blockIdx.y * blockDim.y + threadIdx.y;
  const int j = blockIdx.z;
  if (x >= b.width || y >= b.height || j >= b.neighbours) return;
  const size_t image = static_cast<size_t>(b.width) * b.height;
  b.warped[j * image + static_cast<size_t>(y) * b.width + x] =
      warp_pixel(b.grays + j * image, b.width, b.height,
                 b.homographies + homographies + 9 * j, x, y);
}

__global__ void score_kernel(Buffers b, PlaneArgs plane) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x;
  const int y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x < b.width && y < b.height) score_pixel(b, plane, x, y);
}

__global__ void finish_kernel(Buffers b) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x;
  const int y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x < b.width && y < b.height) finish_pixel(b, x, y);
}

// Host side: what the CPU path computes before its strips start (the grey
// images, the key's texture and the homographies: sweep_setup.h, shared
// with it).

using sweep_setup::plane_homography;

void append_pixels(const cv::Mat& image, std::vector<float>* out) {
  for (int y = 0; y < image.rows; ++y) {
    const float* row = image.ptr<float>(y);
    out->insert(out->end(), row, row + image.cols);
  }
}

// The sweep's inputs, ready to upload.
struct Prepared {
  int width = 0, height = 0, neighbours = 0, window = 0;
  double validity_margin = 0;
  float penalty = 0;
  double min_score = 0, min_margin = 0;
  std::vector<float> key, inverse_std, grays;
  std::vector<double> homographies;
  std::vector<Direction> directions;
  std::vector<PlaneArgs> planes;  // in sweep order
};

Prepared prepare(const DenseView& key,
                 const std::vector<const DenseView*>& neighbours,
                 const std::vector<SweepDirection>& directions,
                 const PlaneSweepOptions& options) {
  Prepared s;
  s.width = key.bgr.cols;
  s.height = key.bgr.rows;
  s.neighbours = static_cast<int>(neighbours.size());
  s.window = options.window;
  s.validity_margin = options.window / 2 + 1;
  s.penalty = static_cast<float>(options.occlusion_penalty);
  s.min_score = options.min_score;
  s.min_margin = options.min_margin;
  const cv::Mat key_gray = sweep_setup::grey_levels(key.bgr);
  append_pixels(key_gray, &s.key);
  append_pixels(sweep_setup::inverse_window_std(key_gray, options.window,
                                                options.min_texture),
                &s.inverse_std);
  for (const DenseView* n : neighbours)
    append_pixels(sweep_setup::grey_levels(n->bgr), &s.grays);

  const Eigen::Matrix3d K_inv = key.K.inverse();
  for (size_t f = 0; f < directions.size(); ++f) {
    const SweepDirection& sweep = directions[f];
    const Eigen::Vector3d n = K_inv.transpose() * sweep.normal;
    Direction dir;
    dir.nx = n.x();
    dir.ny = n.y();
    dir.nz = n.z();
    dir.d_near = sweep.d_near;
    dir.d_far = sweep.d_far;
    dir.planes = sweep.planes;
    s.directions.push_back(dir);
    for (int i = 0; i < sweep.planes; ++i) {
      const double inverse = inverse_offset(dir, i);
      const double step = std::abs(inverse_offset(dir, i + 1) - inverse);
      PlaneArgs plane;
      plane.direction = static_cast<int>(f);
      plane.index = i;
      plane.homographies = s.homographies.size();
      plane.d = static_cast<float>(1 / inverse);
      plane.basin = static_cast<float>(std::max(0.005, 3 * step / inverse));
      plane.nx = dir.nx;
      plane.ny = dir.ny;
      plane.nz = dir.nz;
      s.planes.push_back(plane);
      for (const DenseView* neighbour : neighbours) {
        const Eigen::Matrix3d H =
            plane_homography(key, *neighbour, sweep.normal, 1 / inverse);
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 3; ++c) s.homographies.push_back(H(r, c));
      }
    }
  }
  return s;
}

template <class T>
class DeviceArray {
 public:
  explicit DeviceArray(size_t count) : count_(count) {
    if (count_ > 0) {
      check(cudaMalloc(reinterpret_cast<void**>(&data_), count_ * sizeof(T)),
            "cudaMalloc");
    }
  }
  explicit DeviceArray(const std::vector<T>& host) : DeviceArray(host.size()) {
    if (count_ > 0) {
      check(cudaMemcpy(data_, host.data(), count_ * sizeof(T),
                       cudaMemcpyHostToDevice),
            "upload");
    }
  }
  ~DeviceArray() {
    if (data_ != nullptr) cudaFree(data_);
  }
  DeviceArray(const DeviceArray&) = delete;
  DeviceArray& operator=(const DeviceArray&) = delete;

  T* get() const { return data_; }
  void download(cv::Mat* out) const {
    CV_Assert(out->isContinuous() &&
              out->total() * out->elemSize() == count_ * sizeof(T));
    check(cudaMemcpy(out->data, data_, count_ * sizeof(T),
                     cudaMemcpyDeviceToHost),
          "download");
  }

 private:
  size_t count_;
  T* data_ = nullptr;
};

void check_launch(const char* kernel) { check(cudaGetLastError(), kernel); }

}  // namespace

bool available() {
  static const bool present = [] {
    int count = 0;
    if (cudaGetDeviceCount(&count) != cudaSuccess || count <= 0) {
      cudaGetLastError();  // clear it: no device is not an error here
      return false;
    }
    // A device this build has no kernel image for (CUDA_ARCHITECTURES) is
    // as good as none: the CPU path runs instead of a failing launch.
    cudaFuncAttributes attributes;
    if (cudaFuncGetAttributes(&attributes, init_kernel) != cudaSuccess) {
      cudaGetLastError();
      return false;
    }
    return true;
  }();
  return present;
}

std::string device_name() {
  if (!available()) return "";
  int device = 0;
  cudaDeviceProp properties;
  if (cudaGetDevice(&device) != cudaSuccess ||
      cudaGetDeviceProperties(&properties, device) != cudaSuccess) {
    cudaGetLastError();
    return "";
  }
  return properties.name;
}

void sweep_planes(const DenseView& key,
                  const std::vector<const DenseView*>& neighbours,
                  const std::vector<SweepDirection>& directions,
                  const PlaneSweepOptions& options, DepthMap* map) {
  if (neighbours.empty() || directions.empty()) return;
  for (const cv::Mat* out : {&map->depth, &map->score, &map->margin}) {
    if (out->size() != key.bgr.size() || out->type() != CV_32F ||
        !out->isContinuous())
      throw std::invalid_argument(
          "cuda::sweep_planes: the map must be allocated at the key's size");
  }
  const Prepared s = prepare(key, neighbours, directions, options);
  const size_t image = static_cast<size_t>(s.width) * s.height;

  const DeviceArray<float> key_gray(s.key), inverse_std(s.inverse_std),
      grays(s.grays);
  const DeviceArray<double> homographies(s.homographies);
  const DeviceArray<Direction> sweep_directions(s.directions);
  const DeviceArray<float> warped(image * s.neighbours), previous(image),
      best(image), second(image), before(image), after(image), depth(image),
      out_depth(image), out_score(image), out_margin(image);
  const DeviceArray<int> direction(image), plane(image);

  Buffers b;
  b.width = s.width;
  b.height = s.height;
  b.neighbours = s.neighbours;
  b.window = s.window;
  b.validity_margin = s.validity_margin;
  b.penalty = s.penalty;
  b.min_score = s.min_score;
  b.min_margin = s.min_margin;
  b.key = key_gray.get();
  b.inverse_std = inverse_std.get();
  b.grays = grays.get();
  b.homographies = homographies.get();
  b.directions = sweep_directions.get();
  b.warped = warped.get();
  b.previous = previous.get();
  b.best = best.get();
  b.second = second.get();
  b.before = before.get();
  b.after = after.get();
  b.depth = depth.get();
  b.direction = direction.get();
  b.plane = plane.get();
  b.out_depth = out_depth.get();
  b.out_score = out_score.get();
  b.out_margin = out_margin.get();

  const dim3 block(kBlockX, kBlockY);
  const dim3 grid((s.width + kBlockX - 1) / kBlockX,
                  (s.height + kBlockY - 1) / kBlockY);
  const dim3 warp_grid(grid.x, grid.y, s.neighbours);
  init_kernel<<<grid, block>>>(b);
  check_launch("init_kernel");
  for (const PlaneArgs& p : s.planes) {
    warp_kernel<<<warp_grid, block>>>(b, p.homographies);
    check_launch("warp_kernel");
    score_kernel<<<grid, block>>>(b, p);
    check_launch("score_kernel");
  }
  finish_kernel<<<grid, block>>>(b);
  check_launch("finish_kernel");
  check(cudaDeviceSynchronize(), "plane sweep kernels");
  out_depth.download(&map->depth);
  out_score.download(&map->score);
  out_margin.download(&map->margin);
}

}  // namespace arscout::engine::cuda
