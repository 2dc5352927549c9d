// Points binned on a hash grid for radius queries: the neighbours of a
// place within a radius no larger than the bin's edge are in the 27 bins
// around it.
#pragma once

#include <cmath>
#include <cstdint>
#include <unordered_map>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "mesh/marching_tetrahedra.h"

namespace arscout::engine::mesh {

class PointHash {
 public:
  // Bins `positions` (kept by reference: they must outlive the hash).
  PointHash(const std::vector<Eigen::Vector3f>& positions, double bin);

  // Calls fn(index, squared distance) for each point within `radius`
  // (at most the bin's edge) of `x`.
  template <typename Fn>
  void within(const Eigen::Vector3d& x, double radius, Fn&& fn) const {
    const GridIndex centre = bin_of(x);
    const double r2 = radius * radius;
    for (std::int64_t dz = -1; dz <= 1; ++dz)
      for (std::int64_t dy = -1; dy <= 1; ++dy)
        for (std::int64_t dx = -1; dx <= 1; ++dx) {
          const auto it = bins_.find(
              grid_key({centre[0] + dx, centre[1] + dy, centre[2] + dz}));
          if (it == bins_.end()) continue;
          for (std::uint32_t k = it->second.first; k < it->second.second; ++k) {
            const std::uint32_t i = order_[k];
            const double d2 = (positions_[i].cast<double>() - x).squaredNorm();
            if (d2 <= r2) fn(i, d2);
          }
        }
  }

  GridIndex bin_of(const Eigen::Vector3d& x) const {
    return {static_cast<std::int64_t>(std::floor(x.x() / bin_)),
            static_cast<std::int64_t>(std::floor(x.y() / bin_)),
            static_cast<std::int64_t>(std::floor(x.z() / bin_))};
  }

 private:
  const std::vector<Eigen::Vector3f>& positions_;
  double bin_;
  std::vector<std::uint32_t> order_;  // point indices sorted by bin
  std::unordered_map<std::uint64_t, std::pair<std::uint32_t, std::uint32_t>>
      bins_;  // key -> [begin, end) in order_
};

}  // namespace arscout::engine::mesh
