// Depth maps checked against each other, and the voxel grid they are fused
// into.
#include "dense/consistency.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>

#include <Eigen/Dense>

namespace arscout::engine {
namespace {

// Pixel (x, y) of one depth map at depth z, seen from another camera:
// camera coordinates z * A (x, y, 1) + b, and pixel K c / c.z. A and b
// fold both poses and the first camera's K^-1 together, once per pair
// rather than once per pixel.
class Reprojection {
 public:
  Reprojection(const DepthMap& from, const DepthMap& to) : K_(to.K) {
    const Eigen::Matrix3d R = to.R * from.R.transpose();
    A_ = R * from.K.inverse();
    b_ = to.t - R * from.t;
    width_ = to.depth.cols;
    height_ = to.depth.rows;
  }

  // False when behind the camera or outside its image.
  bool operator()(double x, double y, double z, Eigen::Vector2d* pixel,
                  double* depth) const {
    const Eigen::Vector3d c = z * (A_ * Eigen::Vector3d(x, y, 1)) + b_;
    if (c.z() <= 0) return false;
    const Eigen::Vector3d p = K_ * c;
    *pixel = p.head<2>() / p.z();
    *depth = c.z();
    return pixel->x() >= -0.5 && pixel->y() >= -0.5 &&
           pixel->x() < width_ - 0.5 && pixel->y() < height_ - 0.5;
  }

 private:
  Eigen::Matrix3d K_, A_;
  Eigen::Vector3d b_;
  int width_ = 0, height_ = 0;
};

float depth_at(const DepthMap& map, const Eigen::Vector2d& pixel) {
  const int u = static_cast<int>(std::lround(pixel.x()));
  const int v = static_cast<int>(std::lround(pixel.y()));
  if (u < 0 || v < 0 || u >= map.depth.cols || v >= map.depth.rows) return 0;
  return map.depth.at<float>(v, u);
}

// Rows of `map` run on several threads and may land on the same pixel of
// `other`: the store is atomic (every writer stores the same 255).
void mark_overshoot(cv::Mat* overshoots, const Eigen::Vector2d& pixel) {
  const int u = static_cast<int>(std::lround(pixel.x()));
  const int v = static_cast<int>(std::lround(pixel.y()));
  std::atomic_ref<uint8_t>(overshoots->at<uint8_t>(v, u))
      .store(255, std::memory_order_relaxed);
}

// A sample's score in the integer thousandths a voxel sums.
uint32_t score_units(float score) {
  return static_cast<uint32_t>(
      std::lround(std::clamp(score, 0.0f, 1.0f) * 1000));
}

uint64_t voxel_key(const Eigen::Vector3d& xyz, double size) {
  // 21 bits per axis: +-1 million voxels around the origin, far more than a
  // site needs at any sensible voxel size.
  auto axis = [size](double v) {
    const int64_t i = static_cast<int64_t>(std::floor(v / size));
    return static_cast<uint64_t>(
        std::clamp<int64_t>(i + (1 << 20), 0, (1 << 21) - 1));
  };
  return axis(xyz.x()) << 42 | axis(xyz.y()) << 21 | axis(xyz.z());
}

// The voxel key's x and y fields (voxel_key), shifted down to its block's.
constexpr int kBlockShift = 4;
static_assert(1 << kBlockShift == VoxelCloud::kBlockVoxels);
constexpr uint64_t kAxisMask = (uint64_t{1} << 21) - 1;
// voxel_key's offset (1 << 20) in blocks: a multiple of the block, so a
// block's field is its index plus this.
constexpr long long kBlockOffset = 1LL << (20 - kBlockShift);

uint64_t block_key(long long ix, long long iy) {
  return static_cast<uint64_t>(ix + kBlockOffset) << 32 |
         static_cast<uint64_t>(iy + kBlockOffset);
}

// One counter for every cloud of the process (VoxelCloud::blocks).
std::atomic<uint64_t> last_stamp{0};
uint64_t next_stamp() { return ++last_stamp; }

}  // namespace

PairVerdict judge_pair(const DepthMap& map, const DepthMap& other,
                       const ConsistencyOptions& options) {
  PairVerdict verdict{cv::Mat::zeros(map.depth.size(), CV_8U),
                      cv::Mat::zeros(map.depth.size(), CV_8U),
                      cv::Mat::zeros(other.depth.size(), CV_8U)};
  const double max_px_sq =
      options.max_reprojection_px * options.max_reprojection_px;
  const double free_space = options.free_space_margin;
  const Reprojection forward(map, other), backward(other, map);
  // Rows are independent: the masks are the same for any thread count.
  auto check_rows = [&](const cv::Range& rows) {
    for (int y = rows.start; y < rows.end; ++y) {
      const float* depth = map.depth.ptr<float>(y);
      uint8_t* agrees = verdict.agrees.ptr<uint8_t>(y);
      uint8_t* through = verdict.sees_through.ptr<uint8_t>(y);
      for (int x = 0; x < map.depth.cols; ++x) {
        if (depth[x] <= 0) continue;
        Eigen::Vector2d pixel, back;
        double predicted = 0, unused = 0;
        if (!forward(x, y, depth[x], &pixel, &predicted)) continue;
        const float seen = depth_at(other, pixel);
        if (seen <= 0) continue;
        if (free_space > 0 && seen - predicted > free_space * seen) {
          through[x] = 255;
          mark_overshoot(&verdict.overshoots, pixel);
          continue;
        }
        if (std::abs(seen - predicted) > options.max_relative_depth * seen)
          continue;
        // Backward: the other map's point on the same ray, back in this
        // map (it may land just outside: only the distance matters).
        backward(pixel.x(), pixel.y(), seen, &back, &unused);
        if (unused > 0 &&
            (back - Eigen::Vector2d(x, y)).squaredNorm() <= max_px_sq)
          agrees[x] = 255;
      }
    }
  };
  if (options.parallel)
    cv::parallel_for_(cv::Range(0, map.depth.rows), check_rows);
  else
    check_rows(cv::Range(0, map.depth.rows));
  return verdict;
}

cv::Mat narrow_triangulation(const DepthMap& map,
                             const std::vector<Eigen::Vector3d>& centres,
                             double min_degrees) {
  cv::Mat narrow = cv::Mat::zeros(map.depth.size(), CV_8U);
  if (!(min_degrees > 0) || centres.empty()) return narrow;
  std::vector<Eigen::Vector3d> in_camera;
  for (const Eigen::Vector3d& c : centres)
    in_camera.push_back(map.R * c + map.t);
  const double min_cos = std::cos(min_degrees * M_PI / 180);
  const Eigen::Matrix3d K_inv = map.K.inverse();
  for (int y = 0; y < map.depth.rows; ++y) {
    const float* depth = map.depth.ptr<float>(y);
    uint8_t* out = narrow.ptr<uint8_t>(y);
    for (int x = 0; x < map.depth.cols; ++x) {
      if (depth[x] <= 0) continue;
      const Eigen::Vector3d point =
          depth[x] * (K_inv * Eigen::Vector3d(x, y, 1));
      const Eigen::Vector3d to_map = -point.normalized();
      bool wide = false;
      for (const Eigen::Vector3d& c : in_camera)
        wide = wide || to_map.dot((c - point).normalized()) < min_cos;
      if (!wide) out[x] = 255;
    }
  }
  return narrow;
}

cv::Mat weak_depths(const DepthMap& map,
                    const std::vector<Eigen::Vector3d>& neighbour_centres,
                    const ConsistencyOptions& options) {
  cv::Mat weak = narrow_triangulation(map, neighbour_centres,
                                      options.weak_triangulation_deg);
  if (options.distinct_margin > 0 && map.margin.size() == map.depth.size())
    weak |= (map.margin < options.distinct_margin) & (map.depth > 0);
  return weak;
}

cv::Mat agreement_mask(const DepthMap& map, const DepthMap& other,
                       const ConsistencyOptions& options) {
  ConsistencyOptions agreement_only = options;
  agreement_only.free_space_margin = 0;
  return judge_pair(map, other, agreement_only).agrees;
}

DepthAgreement compare_depth_maps(const DepthMap& a, const DepthMap& b) {
  std::vector<double> differences;
  const Reprojection forward(a, b);
  for (int y = 0; y < a.depth.rows; ++y) {
    for (int x = 0; x < a.depth.cols; ++x) {
      const float z = a.depth.at<float>(y, x);
      if (z <= 0) continue;
      Eigen::Vector2d pixel;
      double predicted = 0;
      if (!forward(x, y, z, &pixel, &predicted)) continue;
      const float seen = depth_at(b, pixel);
      if (seen > 0) differences.push_back(std::abs(predicted - seen) / seen);
    }
  }
  DepthAgreement result;
  result.compared = static_cast<int>(differences.size());
  if (!differences.empty()) {
    auto middle = differences.begin() + differences.size() / 2;
    std::nth_element(differences.begin(), middle, differences.end());
    result.median_relative_difference = *middle;
  }
  return result;
}

VoxelCloud::VoxelCloud(double voxel_size)
    : voxel_size_(voxel_size), stamp_(next_stamp()) {
  if (!(voxel_size > 0))
    throw std::invalid_argument("VoxelCloud: voxel size must be positive");
}

void VoxelCloud::add(const CloudSample& sample) {
  const uint64_t key = voxel_key(sample.xyz, voxel_size_);
  auto [it, inserted] =
      index_.try_emplace(key, static_cast<uint32_t>(voxels_.size()));
  if (inserted) {
    voxels_.emplace_back().block = block_of(key);
    blocks_[voxels_.back().block].voxels.push_back(it->second);
  }
  Voxel& voxel = voxels_[it->second];
  Block& block = blocks_[voxel.block];
  const float x = static_cast<float>(sample.xyz.x());
  const float y = static_cast<float>(sample.xyz.y());
  block.min_x = std::min(block.min_x, x);
  block.max_x = std::max(block.max_x, x);
  block.min_y = std::min(block.min_y, y);
  block.max_y = std::max(block.max_y, y);
  if (voxel.count == 0) ++block.occupied;
  touch(voxel);
  voxel.sum += sample.xyz;
  voxel.normal_sum += sample.normal;
  for (int c = 0; c < 3; ++c) voxel.rgb_sum[c] += sample.rgb[c];
  voxel.support_sum += static_cast<uint32_t>(std::max(0, sample.support));
  voxel.score_sum += score_units(sample.score);
  ++voxel.count;
}

VoxelCloud::Voxel* VoxelCloud::find(const Eigen::Vector3d& xyz) {
  auto it = index_.find(voxel_key(xyz, voxel_size_));
  return it == index_.end() ? nullptr : &voxels_[it->second];
}

bool VoxelCloud::remove(const CloudSample& sample) {
  Voxel* voxel = find(sample.xyz);
  if (!voxel) return false;
  touch(*voxel);
  if (--voxel->count == 0) {
    --blocks_[voxel->block].occupied;
    // Exactly empty, whatever rounding the sums carried.
    *voxel = Voxel{.block = voxel->block};
    index_.erase(voxel_key(sample.xyz, voxel_size_));
    if (voxels_.size() > 1024 && index_.size() < voxels_.size() / 2) compact();
    return true;
  }
  voxel->sum -= sample.xyz;
  voxel->normal_sum -= sample.normal;
  for (int c = 0; c < 3; ++c)
    voxel->rgb_sum[c] -= std::min<uint32_t>(sample.rgb[c], voxel->rgb_sum[c]);
  voxel->support_sum -=
      std::min<uint32_t>(std::max(0, sample.support), voxel->support_sum);
  voxel->score_sum -= std::min(score_units(sample.score), voxel->score_sum);
  return true;
}

bool VoxelCloud::change_support(const Eigen::Vector3d& xyz, int from, int to) {
  Voxel* voxel = find(xyz);
  if (!voxel) return false;
  touch(*voxel);
  voxel->support_sum -=
      std::min<uint32_t>(std::max(0, from), voxel->support_sum);
  voxel->support_sum += static_cast<uint32_t>(std::max(0, to));
  return true;
}

// Drops the emptied slots, keeping the order of the others.
void VoxelCloud::compact() {
  constexpr uint32_t kDropped = std::numeric_limits<uint32_t>::max();
  std::vector<uint32_t> moved_to(voxels_.size(), kDropped);
  size_t kept = 0;
  for (size_t i = 0; i < voxels_.size(); ++i) {
    if (voxels_[i].count == 0) continue;
    moved_to[i] = static_cast<uint32_t>(kept);
    voxels_[kept++] = voxels_[i];
  }
  voxels_.resize(kept);
  for (auto& [key, slot] : index_) slot = moved_to[slot];
  for (Block& block : blocks_) {
    std::erase_if(block.voxels,
                  [&](uint32_t slot) { return moved_to[slot] == kDropped; });
    for (uint32_t& slot : block.voxels) slot = moved_to[slot];
  }
}

void VoxelCloud::clear() {
  voxels_.clear();
  index_.clear();
  blocks_.clear();
  block_index_.clear();
  stamp_ = next_stamp();
}

uint32_t VoxelCloud::block_of(uint64_t voxel_key) {
  const long long ix =
      static_cast<long long>((voxel_key >> 42 & kAxisMask) >> kBlockShift) -
      kBlockOffset;
  const long long iy =
      static_cast<long long>((voxel_key >> 21 & kAxisMask) >> kBlockShift) -
      kBlockOffset;
  auto [it, inserted] = block_index_.try_emplace(
      block_key(ix, iy), static_cast<uint32_t>(blocks_.size()));
  if (inserted) {
    blocks_.emplace_back();
    blocks_.back().ix = ix;
    blocks_.back().iy = iy;
  }
  return it->second;
}

std::vector<CloudBlock> VoxelCloud::blocks() const {
  std::vector<CloudBlock> out;
  out.reserve(blocks_.size());
  for (const Block& block : blocks_)
    out.push_back({block.ix, block.iy, block.changed, block.occupied,
                   block.min_x, block.min_y, block.max_x, block.max_y});
  return out;
}

uint64_t VoxelCloud::mark() {
  const uint64_t mark = stamp_;
  stamp_ = next_stamp();
  return mark;
}

std::vector<ColoredPoint> VoxelCloud::points_in(
    const Eigen::Vector2d& lo, const Eigen::Vector2d& hi) const {
  // A block more on each side: a mean rounded to float may cross its edge.
  const double edge = block_edge();
  const double x0 = std::floor(lo.x() / edge) - 1,
               x1 = std::floor(hi.x() / edge) + 1;
  const double y0 = std::floor(lo.y() / edge) - 1,
               y1 = std::floor(hi.y() / edge) + 1;
  std::vector<uint32_t> slots;
  const auto take = [&](const Block& block) {
    if (block.ix >= x0 && block.ix <= x1 && block.iy >= y0 && block.iy <= y1)
      slots.insert(slots.end(), block.voxels.begin(), block.voxels.end());
  };
  if (!((x1 - x0 + 1) * (y1 - y0 + 1) < static_cast<double>(blocks_.size()))) {
    for (const Block& block : blocks_)
      take(block);  // as cheap as a lookup each
  } else {
    for (auto ix = static_cast<long long>(x0); ix <= x1; ++ix)
      for (auto iy = static_cast<long long>(y0); iy <= y1; ++iy)
        if (const auto it = block_index_.find(block_key(ix, iy));
            it != block_index_.end())
          take(blocks_[it->second]);
  }
  std::sort(slots.begin(), slots.end());  // the cloud's order
  std::vector<ColoredPoint> points;
  for (const uint32_t slot : slots) {
    if (voxels_[slot].count == 0) continue;
    const ColoredPoint p = mean_of(voxels_[slot]);
    if (p.x >= lo.x() && p.x < hi.x() && p.y >= lo.y() && p.y < hi.y())
      points.push_back(p);
  }
  return points;
}

std::vector<ColoredPoint> VoxelCloud::points() const {
  std::vector<ColoredPoint> points;
  points.reserve(index_.size());
  for (const Voxel& voxel : voxels_)
    if (voxel.count > 0) points.push_back(mean_of(voxel));
  return points;
}

ColoredPoint VoxelCloud::mean_of(const Voxel& voxel) const {
  const Eigen::Vector3d mean = voxel.sum / voxel.count;
  ColoredPoint p;
  p.x = static_cast<float>(mean.x());
  p.y = static_cast<float>(mean.y());
  p.z = static_cast<float>(mean.z());
  p.r =
      static_cast<uint8_t>((voxel.rgb_sum[0] + voxel.count / 2) / voxel.count);
  p.g =
      static_cast<uint8_t>((voxel.rgb_sum[1] + voxel.count / 2) / voxel.count);
  p.b =
      static_cast<uint8_t>((voxel.rgb_sum[2] + voxel.count / 2) / voxel.count);
  const float length = voxel.normal_sum.norm();
  if (length > 0) {
    p.nx = voxel.normal_sum.x() / length;
    p.ny = voxel.normal_sum.y() / length;
    p.nz = voxel.normal_sum.z() / length;
  }
  p.support = static_cast<uint8_t>(std::min<uint32_t>(
      255, (voxel.support_sum + voxel.count / 2) / voxel.count));
  p.score = static_cast<uint8_t>(std::min<long>(
      255, std::lround(255.0 * voxel.score_sum / (1000.0 * voxel.count))));
  return p;
}

}  // namespace arscout::engine
