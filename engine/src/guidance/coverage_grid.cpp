#include "guidance/coverage_grid.h"

#include <algorithm>
#include <cmath>
#include <set>

#include <Eigen/Dense>

namespace arscout::engine::guidance {
namespace {

constexpr double kPi = 3.14159265358979323846;
// Sight lines carved per analysis at most: beyond, every n-th observation.
constexpr std::size_t kMaxSightLines = 400000;

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

std::vector<Sighted> sighted_points(const Model& model) {
  std::vector<Sighted> out;
  out.reserve(model.points.size());
  for (const ModelPoint& p : model.points) {
    Sighted s{{p.xyz[0], p.xyz[1]}, p.xyz[2], {}};
    for (const auto& [image, keypoint] : p.track) s.images.push_back(image);
    std::sort(s.images.begin(), s.images.end());
    s.images.erase(std::unique(s.images.begin(), s.images.end()),
                   s.images.end());
    if (s.images.size() >= 2) out.push_back(std::move(s));
  }
  return out;
}

bool is_facade(const GroundGrid& g, const Sighted& p,
               const CoverageOptions& options) {
  return p.z > g.ground_at(p.xy) + options.min_facade_height_m;
}

// Least squares over the photos, then again without those more than a
// metre off (a photo from a balcony); level through the median when the
// photos do not span both ground directions by a few metres.
std::array<double, 3> fit_ground(const Model& model, const Vec2& mean,
                                 double camera_height) {
  std::vector<double> heights;
  for (const ModelImage& image : model.images)
    heights.push_back(image.centre[2] - camera_height);
  std::array<double, 3> plane{0, 0, median(heights)};
  for (int pass = 0; pass < 2; ++pass) {
    Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
    Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
    Eigen::Matrix2d spread = Eigen::Matrix2d::Zero();
    for (std::size_t i = 0; i < heights.size(); ++i) {
      const auto& c = model.images[i].centre;
      if (std::abs(plane[0] * c[0] + plane[1] * c[1] + plane[2] - heights[i]) >
          1.0)
        continue;
      const Eigen::Vector3d row(c[0], c[1], 1);
      normal += row * row.transpose();
      rhs += row * heights[i];
      const Eigen::Vector2d d(c[0] - mean[0], c[1] - mean[1]);
      spread += d * d.transpose();
    }
    if (normal(2, 2) < 6 ||
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(spread / normal(2, 2))
                .eigenvalues()
                .minCoeff() < 4.0)
      break;  // fewer than 6 photos, or spread less than 2 m across
    const Eigen::Vector3d x = normal.ldlt().solve(rhs);
    plane = {x.x(), x.y(), x.z()};
  }
  return plane;
}

// The ground, which points are facade above it, and the standoff.
void measure_ground_and_standoff(const Model& model,
                                 const CoverageOptions& options,
                                 GroundGrid& g) {
  Vec2 centroid{0, 0};
  for (const ModelImage& image : model.images)
    for (int a = 0; a < 2; ++a)
      centroid[a] += image.centre[a] / static_cast<double>(model.images.size());
  g.ground = fit_ground(model, centroid, options.camera_height_m);
  g.ground_z = g.ground_at(centroid);
  std::vector<double> ranges;
  for (Sighted& p : g.points) {
    p.facade = is_facade(g, p, options);
    if (!p.facade) continue;
    for (int image : p.images)
      ranges.push_back(distance(p.xy, centre_xy(model.images[image])));
  }
  g.standoff = std::clamp(median(ranges), 3.0, 30.0);
}

// Over the photos and the points, padded by the standoff so that places in
// front of an outer facade are on it; the cell grows to keep the grid
// within options.max_cells_per_side.
Grid make_grid(const Model& model, const GroundGrid& g,
               const CoverageOptions& options) {
  Vec2 lo{1e300, 1e300}, hi{-1e300, -1e300};
  const auto extend = [&](const Vec2& p) {
    for (int a = 0; a < 2; ++a) {
      lo[a] = std::min(lo[a], p[a]);
      hi[a] = std::max(hi[a], p[a]);
    }
  };
  for (const Sighted& p : g.points) extend(p.xy);
  for (const ModelImage& image : model.images) extend(centre_xy(image));
  const double pad = g.standoff + 2 * options.cell_m;
  const Vec2 size{hi[0] - lo[0] + 2 * pad, hi[1] - lo[1] + 2 * pad};
  Grid grid;
  grid.cell = std::max(options.cell_m, std::max(size[0], size[1]) /
                                           (options.max_cells_per_side - 1));
  grid.origin = {lo[0] - pad, lo[1] - pad};
  grid.columns = static_cast<int>(std::ceil(size[0] / grid.cell)) + 1;
  grid.rows = static_cast<int>(std::ceil(size[1] / grid.cell)) + 1;
  return grid;
}

// Each facade point's cell gets the point, the photos that see it by
// sector, and the directions toward them (the facade faces them).
void sight_facades(const Model& model, GroundGrid& g) {
  for (const Sighted& p : g.points) {
    const int i = g.grid.index(p.xy);
    if (i < 0 || !p.facade) continue;
    CellState& cell = g.cells[i];
    ++cell.points;
    for (int image : p.images) {
      const Vec2 cam = centre_xy(model.images[image]);
      const double range = distance(cam, p.xy);
      if (!(range > 0)) continue;
      const Vec2 toward{(cam[0] - p.xy[0]) / range, (cam[1] - p.xy[1]) / range};
      cell.sightings.emplace_back(sector_of(bearing_of(toward)), image);
      cell.facing[0] += toward[0];
      cell.facing[1] += toward[1];
    }
  }
}

// The cells a sight line crosses are seen empty, short of the cell of what
// it sees and that cell's neighbours.
void carve(GroundGrid& g, const Vec2& from, const Vec2& to) {
  const double full = distance(from, to);
  const double length = full - 1.5 * g.grid.cell;
  for (double s = 0; s < length; s += g.grid.cell / 2) {
    const double t = s / full;
    const int i = g.grid.index(
        {from[0] + t * (to[0] - from[0]), from[1] + t * (to[1] - from[1])});
    if (i >= 0) g.cells[i].seen_empty = true;
  }
}

void carve_sight_lines(const Model& model, GroundGrid& g) {
  for (const ModelImage& image : model.images)
    g.cameras.push_back(centre_xy(image));
  std::size_t lines = 0;
  for (const Sighted& p : g.points) lines += p.images.size();
  const std::size_t stride = lines / kMaxSightLines + 1;
  std::size_t n = 0;
  for (std::size_t k = 0; k < g.points.size(); ++k)
    for (int image : g.points[k].images)
      if (n++ % stride == 0) {
        carve(g, g.cameras[image], g.points[k].xy);
        g.sight_lines.emplace_back(image, static_cast<int>(k));
      }
}

}  // namespace

double bearing_of(const Vec2& d) {
  const double deg = std::atan2(d[0], d[1]) * 180 / kPi;
  return deg < 0 ? deg + 360 : deg;
}

Vec2 unit_of_bearing(double deg) {
  return {std::sin(deg * kPi / 180), std::cos(deg * kPi / 180)};
}

int sector_of(double bearing_deg) {
  const double b = std::fmod(std::fmod(bearing_deg, 360) + 360, 360);
  return static_cast<int>(std::floor((b + 22.5) / 45)) % 8;
}

double distance(const Vec2& a, const Vec2& b) {
  return std::hypot(a[0] - b[0], a[1] - b[1]);
}

Vec2 centre_xy(const ModelImage& image) {
  return {image.centre[0], image.centre[1]};
}

int Grid::index(const Vec2& p) const {
  const double c = std::floor((p[0] - origin[0]) / cell);
  const double r = std::floor((p[1] - origin[1]) / cell);
  if (!(c >= 0 && r >= 0 && c < columns && r < rows)) return -1;
  return static_cast<int>(r) * columns + static_cast<int>(c);
}

Vec2 Grid::centre(int i) const {
  const int column = i % columns, row = i / columns;
  return {origin[0] + (column + 0.5) * cell, origin[1] + (row + 0.5) * cell};
}

bool GroundGrid::facade_near(int i) const {
  if (i < 0) return false;
  const int c = i % grid.columns, r = i / grid.columns;
  for (int dr = -1; dr <= 1; ++dr)
    for (int dc = -1; dc <= 1; ++dc) {
      const int cc = c + dc, rr = r + dr;
      if (cc >= 0 && rr >= 0 && cc < grid.columns && rr < grid.rows &&
          cells[rr * grid.columns + cc].points > 0)
        return true;
    }
  return false;
}

GroundGrid build_ground_grid(const Model& model,
                             const CoverageOptions& options) {
  GroundGrid g;
  g.points = sighted_points(model);
  measure_ground_and_standoff(model, options, g);
  g.grid = make_grid(model, g, options);
  g.cells.resize(g.grid.size());
  sight_facades(model, g);
  carve_sight_lines(model, g);
  return g;
}

CoverageCell summarise_cell(const GroundGrid& g, int i) {
  const CellState& s = g.cells[i];
  CoverageCell cell;
  cell.column = i % g.grid.columns;
  cell.row = i / g.grid.columns;
  cell.centre = g.grid.centre(i);
  cell.points = s.points;
  const std::set<std::pair<int, int>> by_sector(s.sightings.begin(),
                                                s.sightings.end());
  std::set<int> images;
  for (const auto& [sector, image] : by_sector) {
    images.insert(image);
    ++cell.sectors[sector];
  }
  cell.views = static_cast<int>(images.size());
  for (int count : cell.sectors) cell.directions += count > 0;
  cell.facing_deg = bearing_of(s.facing);
  return cell;
}

}  // namespace arscout::engine::guidance
