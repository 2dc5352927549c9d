#include "mesh/marching_tetrahedra.h"

#include <cmath>
#include <unordered_map>
#include <utility>

namespace arscout::engine::mesh {
namespace {

constexpr std::int64_t kAxisOffset = std::int64_t{1} << 20;

// The six tetrahedra of a cube, as corner offsets (bit 0: x, 1: y, 2: z):
// each walks from corner 0 to corner 7 adding one axis at a time, in one
// of the six orders, so neighbouring cubes cut a shared face the same way.
constexpr std::array<std::array<int, 4>, 6> kTetrahedra = {{
    {0, 1, 3, 7},
    {0, 1, 5, 7},
    {0, 2, 3, 7},
    {0, 2, 6, 7},
    {0, 4, 5, 7},
    {0, 4, 6, 7},
}};

GridIndex corner_of(const GridIndex& cube, int bits) {
  return {cube[0] + (bits & 1), cube[1] + ((bits >> 1) & 1),
          cube[2] + ((bits >> 2) & 1)};
}

struct PairHash {
  std::size_t operator()(
      const std::pair<std::uint64_t, std::uint64_t>& p) const {
    return std::hash<std::uint64_t>()(p.first * 0x9E3779B97F4A7C15ull ^
                                      p.second);
  }
};

struct Corner {
  GridIndex index;
  std::uint64_t key = 0;
  float value = 0;
};

class Builder {
 public:
  explicit Builder(double cell) : cell_(cell) {}

  void tetrahedron(const std::array<const Corner*, 4>& c) {
    std::array<int, 4> inside{}, outside{};
    int n_in = 0, n_out = 0;
    for (int i = 0; i < 4; ++i) {
      if (c[i]->value < 0)
        inside[n_in++] = i;
      else
        outside[n_out++] = i;
    }
    if (n_in == 0 || n_out == 0) return;
    const Eigen::Vector3d toward_outside =
        position(*c[outside[0]]) - position(*c[inside[0]]);
    if (n_in == 1 || n_out == 1) {
      const bool lone_inside = n_in == 1;
      const int lone = lone_inside ? inside[0] : outside[0];
      const auto& others = lone_inside ? outside : inside;
      triangle(
          {vertex(*c[lone], *c[others[0]]), vertex(*c[lone], *c[others[1]]),
           vertex(*c[lone], *c[others[2]])},
          toward_outside);
      return;
    }
    // Two and two: the four crossing edges form a quad, a0-b0, a0-b1,
    // a1-b1, a1-b0 in order around it.
    const std::uint32_t v00 = vertex(*c[inside[0]], *c[outside[0]]);
    const std::uint32_t v01 = vertex(*c[inside[0]], *c[outside[1]]);
    const std::uint32_t v11 = vertex(*c[inside[1]], *c[outside[1]]);
    const std::uint32_t v10 = vertex(*c[inside[1]], *c[outside[0]]);
    triangle({v00, v01, v11}, toward_outside);
    triangle({v00, v11, v10}, toward_outside);
  }

  IsoSurface take() { return std::move(surface_); }

 private:
  Eigen::Vector3d position(const Corner& c) const {
    return Eigen::Vector3d(static_cast<double>(c.index[0]),
                           static_cast<double>(c.index[1]),
                           static_cast<double>(c.index[2])) *
           cell_;
  }

  // The crossing on edge a-b (values of opposite signs), once per edge.
  std::uint32_t vertex(const Corner& a, const Corner& b) {
    const auto key = a.key < b.key ? std::make_pair(a.key, b.key)
                                   : std::make_pair(b.key, a.key);
    const auto [it, added] = vertices_.try_emplace(
        key, static_cast<std::uint32_t>(surface_.positions.size()));
    if (added) {
      // Interpolated from the lower key's side, so both cubes (and tiles)
      // sharing the edge compute the same bits.
      const Corner& lo = a.key < b.key ? a : b;
      const Corner& hi = a.key < b.key ? b : a;
      const double s = lo.value / (static_cast<double>(lo.value) - hi.value);
      surface_.positions.push_back(position(lo) +
                                   s * (position(hi) - position(lo)));
    }
    return it->second;
  }

  void triangle(std::array<std::uint32_t, 3> v,
                const Eigen::Vector3d& toward_outside) {
    if (v[0] == v[1] || v[1] == v[2] || v[0] == v[2]) return;
    const auto& p = surface_.positions;
    const Eigen::Vector3d normal = (p[v[1]] - p[v[0]]).cross(p[v[2]] - p[v[0]]);
    if (normal.dot(toward_outside) < 0) std::swap(v[1], v[2]);
    surface_.indices.insert(surface_.indices.end(), v.begin(), v.end());
  }

  double cell_;
  IsoSurface surface_;
  std::unordered_map<std::pair<std::uint64_t, std::uint64_t>, std::uint32_t,
                     PairHash>
      vertices_;
};

}  // namespace

std::uint64_t grid_key(const GridIndex& i) {
  const auto axis = [](std::int64_t v) {
    return static_cast<std::uint64_t>(v + kAxisOffset) & 0x1FFFFFu;
  };
  return axis(i[0]) | (axis(i[1]) << 21) | (axis(i[2]) << 42);
}

IsoSurface polygonise(
    const std::vector<GridIndex>& cubes, double cell,
    const std::function<std::optional<float>(const GridIndex&)>& value,
    double max_abs_value) {
  Builder builder(cell);
  for (const GridIndex& cube : cubes) {
    std::array<Corner, 8> corners;
    bool usable = true, negative = false, positive = false;
    for (int bits = 0; bits < 8 && usable; ++bits) {
      Corner& c = corners[bits];
      c.index = corner_of(cube, bits);
      c.key = grid_key(c.index);
      const std::optional<float> v = value(c.index);
      usable = v && std::abs(*v) <= max_abs_value;
      if (!usable) break;
      c.value = *v;
      (c.value < 0 ? negative : positive) = true;
    }
    if (!usable || !negative || !positive) continue;
    for (const auto& tet : kTetrahedra)
      builder.tetrahedron({&corners[tet[0]], &corners[tet[1]], &corners[tet[2]],
                           &corners[tet[3]]});
  }
  return builder.take();
}

}  // namespace arscout::engine::mesh
