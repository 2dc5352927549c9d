#include "mesh/point_hash.h"

#include <algorithm>
#include <numeric>

namespace arscout::engine::mesh {

PointHash::PointHash(const std::vector<Eigen::Vector3f>& positions, double bin)
    : positions_(positions), bin_(bin) {
  std::vector<std::uint64_t> keys(positions.size());
  for (std::size_t i = 0; i < positions.size(); ++i)
    keys[i] = grid_key(bin_of(positions[i].cast<double>()));
  order_.resize(positions.size());
  std::iota(order_.begin(), order_.end(), 0u);
  std::stable_sort(
      order_.begin(), order_.end(),
      [&](std::uint32_t a, std::uint32_t b) { return keys[a] < keys[b]; });
  bins_.reserve(positions.size() / 4 + 1);
  for (std::uint32_t k = 0; k < order_.size();) {
    std::uint32_t end = k + 1;
    while (end < order_.size() && keys[order_[end]] == keys[order_[k]]) ++end;
    bins_.emplace(keys[order_[k]], std::make_pair(k, end));
    k = end;
  }
}

}  // namespace arscout::engine::mesh
