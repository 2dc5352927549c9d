// The block scene (synthetic_site.h): a loop walk around a city block with
// a courtyard, and the buildings generated to fit it.
//
// While building, everything lives in a local frame: the route is the
// rectangle (0, 0)-(a, b), walked counterclockwise from (0, 0) along the
// legs S (east), E (north), N (west) and W (south), with arc length s
// measured along it from (0, 0). The inner block is on the walker's left,
// the outer ring on the right. The finished scene is turned by a seeded
// heading and moved so that the route's centre is the origin.
#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <vector>

#include <Eigen/Dense>

#include "arscout/engine/synthetic_site.h"

namespace arscout::engine::synthetic {
namespace {

constexpr double kPi = 3.14159265358979323846;

double radians(double degrees) { return degrees * kPi / 180; }

double ramp(double x) { return std::clamp(x, 0.0, 1.0); }

// Walk per photo, counting bursts: sets the loop's perimeter.
constexpr double kWalkPerPhoto = 0.85;
// Half the width of a courtyard gateway: the walker passes 3 m from walls.
constexpr double kGateHalfWidth = 3;
// The route's heading turns over this distance either side of a corner (the
// path itself keeps its sharp corners), so headings follow it smoothly.
constexpr double kCornerBlend = 3;

// The rectangle route and its legs, k = 0 (S), 1 (E), 2 (N), 3 (W).
struct Route {
  double a = 0;  // length of S and N, along x
  double b = 0;  // length of E and W, along y

  double perimeter() const { return 2 * (a + b); }
  double length(int k) const { return k % 2 == 0 ? a : b; }
  double start(int k) const {
    const double starts[] = {0, a, a + b, 2 * a + b};
    return starts[k];
  }
  Eigen::Vector2d origin(int k) const {
    const Eigen::Vector2d origins[] = {{0, 0}, {a, 0}, {a, b}, {0, b}};
    return origins[k];
  }
  Eigen::Vector2d direction(int k) const {
    const Eigen::Vector2d directions[] = {{1, 0}, {0, 1}, {-1, 0}, {0, -1}};
    return directions[k];
  }
  // Towards the inner block.
  Eigen::Vector2d left(int k) const {
    const Eigen::Vector2d d = direction(k);
    return {-d.y(), d.x()};
  }
  int leg(double s) const {
    s = wrap(s);
    int k = 0;
    while (k < 3 && s >= start(k + 1)) ++k;
    return k;
  }
  double wrap(double s) const {
    const double p = perimeter();
    s = std::fmod(s, p);
    return s < 0 ? s + p : s;
  }
  Eigen::Vector2d point(double s) const {
    const int k = leg(s);
    return origin(k) + (wrap(s) - start(k)) * direction(k);
  }
};

struct Layout {
  Route route;
  double inner = 0;     // route to the inner block's facades
  double outer = 0;     // route to the outer ring's facades
  double recess = 0;    // how much further back the courtyard's outer walls are
  double gate_in = 0;   // arc length of the gateway on the E leg
  double gate_out = 0;  // arc length of the second gateway (N or W leg)

  bool in_courtyard(double s) const {
    s = route.wrap(s);
    return s >= gate_in && s <= gate_out;
  }
  double outer_at(double s) const {
    return outer + (in_courtyard(s) ? recess : 0);
  }
};

Layout make_layout(SplitMix64& rng, int views) {
  Layout layout;
  const double walk = kWalkPerPhoto * views * rng.uniform(0.95, 1.05);
  // Narrow streets keep the smallest loop short (56 m, round one 6 m
  // building) and its views on nearby walls.
  const double roomy = ramp((walk - 56) / 40);
  layout.inner = 4 + 1.5 * roomy * rng.uniform();
  layout.outer = 5 + 2.5 * roomy * rng.uniform();
  layout.recess = rng.uniform(1.0, 2.5);
  const double min_side = 2 * layout.inner + 6;
  const double half = std::max(0.5 * walk, 2 * min_side);
  const double ratio = rng.uniform(0.6, 1.6);  // a / b
  Route& route = layout.route;
  route.a = std::clamp(half * ratio / (1 + ratio), min_side, half - min_side);
  route.b = half - route.a;
  // A gateway's inner wall must meet the block's facade, which stops
  // `inner` short of each corner.
  const double q_min = layout.inner + 1.5;
  const double ne = route.start(2);
  layout.gate_in = ne - rng.uniform(q_min, std::min(12.0, route.b - q_min));
  if (route.a <= 26) {
    // A short north side lies wholly in the courtyard.
    layout.gate_out =
        route.start(3) + rng.uniform(q_min, std::min(12.0, route.b - q_min));
  } else {
    layout.gate_out = ne + rng.uniform(std::max(q_min, 7.0), 12.0);
  }
  return layout;
}

// ---- Buildings ----

struct Box {
  double x0, x1, y0, y1;  // footprint
  double height;
};

// Mostly noise, whose every patch is unique and strongly textured. Plaster
// (fainter) and brick (periodic, which misleads matching) only on faces
// narrow enough never to fill a view.
Texture wall_texture(SplitMix64& rng, double width) {
  const double u = rng.uniform();
  if (u < 0.75 || width > 12) return Texture::kNoise;
  if (u < 0.92 || width > 10) return Texture::kPlaster;
  return Texture::kBrick;
}

uint32_t texture_seed(SplitMix64& rng) {
  return static_cast<uint32_t>(rng.next() >> 32);
}

// Four walls with edge_u x edge_v pointing out and edge_v up (upright
// textures), and a roof.
void add_box(const Box& box, SplitMix64& rng, std::vector<Quad>& quads) {
  const double w = box.x1 - box.x0, d = box.y1 - box.y0;
  const Eigen::Vector3d up(0, 0, box.height);
  const auto wall = [&](Eigen::Vector3d corner, Eigen::Vector3d edge_u) {
    quads.push_back({corner, edge_u, up, wall_texture(rng, edge_u.norm()),
                     texture_seed(rng)});
  };
  wall({box.x0, box.y0, 0}, {w, 0, 0});   // south
  wall({box.x1, box.y0, 0}, {0, d, 0});   // east
  wall({box.x1, box.y1, 0}, {-w, 0, 0});  // north
  wall({box.x0, box.y1, 0}, {0, -d, 0});  // west
  quads.push_back({{box.x0, box.y0, box.height},
                   {w, 0, 0},
                   {0, d, 0},
                   Texture::kNoise,
                   texture_seed(rng)});
}

// Splits [t0, t1] into building widths of 6-25 m (mostly 7-18); a stretch
// under 6 m stays one piece.
std::vector<double> partition(double t0, double t1, SplitMix64& rng) {
  std::vector<double> cuts = {t0};
  double rest = t1 - t0;
  while (rest > 25) {
    const double width = std::min(rng.uniform(7, 18), rest - 6);
    cuts.push_back(cuts.back() + width);
    rest -= width;
  }
  cuts.push_back(t1);
  return cuts;
}

// The axis-aligned box over leg k's coordinates [t0, t1] along the leg and
// [c0, c1] across it (positive to the left).
Box leg_box(const Route& route, int k, double t0, double t1, double c0,
            double c1, double height) {
  const Eigen::Vector2d p =
      route.origin(k) + t0 * route.direction(k) + c0 * route.left(k);
  const Eigen::Vector2d q =
      route.origin(k) + t1 * route.direction(k) + c1 * route.left(k);
  return {std::min(p.x(), q.x()), std::max(p.x(), q.x()),
          std::min(p.y(), q.y()), std::max(p.y(), q.y()), height};
}

// The outer ring's row along leg k, running past both ends far enough to
// close the corners with the neighbouring rows. Breaks at the gateways,
// where the courtyard's walls step back.
void add_outer_row(const Layout& layout, int k, double depth, SplitMix64& rng,
                   std::vector<Quad>& quads) {
  const Route& route = layout.route;
  const double length = route.length(k), start = route.start(k);
  const double before = layout.outer_at(start - 0.1) + depth + 1;
  const double after = layout.outer_at(start + length + 0.1) + depth + 1;
  std::vector<double> breaks = {-before};
  for (const double gate : {layout.gate_in, layout.gate_out}) {
    if (gate > start && gate < start + length) breaks.push_back(gate - start);
  }
  breaks.push_back(length + after);
  for (size_t i = 0; i + 1 < breaks.size(); ++i) {
    const double middle =
        std::clamp(0.5 * (breaks[i] + breaks[i + 1]), 0.0, length);
    const double offset = layout.outer_at(start + middle);
    const std::vector<double> cuts = partition(breaks[i], breaks[i + 1], rng);
    for (size_t j = 0; j + 1 < cuts.size(); ++j) {
      // Set back by up to 0.6 m: facades that do not line up give depth
      // structure.
      const double c = offset + rng.uniform(0, 0.6);
      add_box(leg_box(route, k, cuts[j], cuts[j + 1], -c, -(c + depth),
                      rng.uniform(5, 15)),
              rng, quads);
    }
  }
}

// The buildings inside the route: one for a small block, a row of slabs
// across a narrow one, else a ring (its hidden inside left empty).
void add_inner_block(const Layout& layout, SplitMix64& rng,
                     std::vector<Quad>& quads) {
  const double x0 = layout.inner, x1 = layout.route.a - layout.inner;
  const double y0 = layout.inner, y1 = layout.route.b - layout.inner;
  const double depth = rng.uniform(8, 12);
  const auto height = [&] { return rng.uniform(6, 15); };
  if (x1 - x0 <= 25 && y1 - y0 <= 25) {
    add_box({x0, x1, y0, y1, height()}, rng, quads);
  } else if (std::min(x1 - x0, y1 - y0) < 2 * depth + 6) {
    const bool along_x = x1 - x0 >= y1 - y0;
    const std::vector<double> cuts =
        along_x ? partition(x0, x1, rng) : partition(y0, y1, rng);
    for (size_t j = 0; j + 1 < cuts.size(); ++j) {
      add_box(along_x ? Box{cuts[j], cuts[j + 1], y0, y1, height()}
                      : Box{x0, x1, cuts[j], cuts[j + 1], height()},
              rng, quads);
    }
  } else {
    // Each side's row, set back from the street by up to 0.5 m; S and N
    // take the corners.
    const auto sb = [&] { return rng.uniform(0, 0.5); };
    std::vector<double> cuts = partition(x0, x1, rng);
    for (size_t j = 0; j + 1 < cuts.size(); ++j) {
      const double s = sb(), n = sb();
      add_box({cuts[j], cuts[j + 1], y0 + s, y0 + s + depth, height()}, rng,
              quads);
      add_box({cuts[j], cuts[j + 1], y1 - n - depth, y1 - n, height()}, rng,
              quads);
    }
    cuts = partition(y0 + depth, y1 - depth, rng);
    for (size_t j = 0; j + 1 < cuts.size(); ++j) {
      const double w = sb(), e = sb();
      add_box({x0 + w, x0 + w + depth, cuts[j], cuts[j + 1], height()}, rng,
              quads);
      add_box({x1 - e - depth, x1 - e, cuts[j], cuts[j + 1], height()}, rng,
              quads);
    }
  }
}

// A wall 1 m thick across the street with a gateway centred on the route,
// reaching 1.5 m into the buildings on both sides so that nothing shows
// through beside it.
void add_gate(const Layout& layout, double s, SplitMix64& rng,
              std::vector<Quad>& quads) {
  const Route& route = layout.route;
  const int k = route.leg(s);
  const double t = s - route.start(k);
  const double height = rng.uniform(4, 6);
  const double far_side = layout.outer + layout.recess + 0.6 + 1.5;
  add_box(leg_box(route, k, t - 0.5, t + 0.5, kGateHalfWidth,
                  layout.inner + 1.5, height),
          rng, quads);
  add_box(
      leg_box(route, k, t - 0.5, t + 0.5, -kGateHalfWidth, -far_side, height),
      rng, quads);
}

Site make_site(const Layout& layout, SplitMix64& rng) {
  Site site;
  auto& quads = site.quads;
  const Route& route = layout.route;
  const double margin = 60;
  quads.push_back({{-margin, -margin, 0},
                   {route.a + 2 * margin, 0, 0},
                   {0, route.b + 2 * margin, 0},
                   Texture::kAsphalt,
                   texture_seed(rng)});
  add_inner_block(layout, rng, quads);
  const double outer_depth = rng.uniform(8, 12);
  for (int k = 0; k < 4; ++k) add_outer_row(layout, k, outer_depth, rng, quads);
  add_gate(layout, layout.gate_in, rng, quads);
  add_gate(layout, layout.gate_out, rng, quads);
  return site;
}

// ---- The walk ----

// Where the walker is and where they look, as functions of the walk
// coordinate w = s - start in [0, perimeter].
//
// They look at the block, a little ahead on their left. At the NE corner, in
// the courtyard, they turn to the outer walls on their right (cheap: the corner
// itself turns them left), with more photos sweeping further round first;
// they keep to the outer row along the N leg, and after the NW corner turn
// back to the block clockwise, through looking back up the W leg at the
// near outer row. Turning through straight ahead there would cost the
// corner's quarter turn on top, and down a long street.
struct Walk {
  Layout layout;
  double start = 0;                // arc length of the first photo
  std::array<double, 4> corner{};  // w of the SE, NE, NW and SW corners
  double sweep_deg = 0;            // extra clockwise turn about the NE corner
  double sweep_half = 0;           // the sweep's half-length, m
  double back_len = 0;    // the turn back to the block after the NW corner
  double right_deg = 80;  // the outer row, this far right of ahead
  std::array<double, 2> wobble_phase{};
  std::array<int, 2> wobble_cycles{1, 1};
  double pitch_deg = -5;

  double perimeter() const { return layout.route.perimeter(); }
  double arc(double w) const { return layout.route.wrap(start + w); }
  double ne() const { return corner[1]; }
  double nw() const { return corner[2]; }
  double back_start() const { return nw() + 1; }
  double back_end() const { return back_start() + back_len; }
};

Walk make_walk(const Layout& layout, int views, SplitMix64& rng) {
  Walk walk;
  walk.layout = layout;
  const Route& route = layout.route;
  walk.start = route.a * rng.uniform(0.3, 0.6);
  for (int k = 0; k < 4; ++k) {
    walk.corner[k] = route.start(k + 1 < 4 ? k + 1 : 0) - walk.start;
  }
  walk.corner[3] = route.perimeter() - walk.start;
  // The sweep stays inside the courtyard.
  const double q1 = route.start(2) - layout.gate_in;
  walk.sweep_half = std::min(q1 - 1.5, 10.0);
  walk.sweep_deg = std::clamp(0.5 * (views - 60), 0.0, 150.0);
  walk.back_len = std::min(12.0, route.b - kCornerBlend - 3);
  for (int i = 0; i < 2; ++i) {
    walk.wobble_phase[i] = rng.uniform(0, 2 * kPi);
    // Whole cycles round the loop, so the last photos look as the first.
    walk.wobble_cycles[i] =
        std::max(1, static_cast<int>(route.perimeter() / rng.uniform(25, 45)));
  }
  walk.pitch_deg = rng.uniform(-5.7, -5.3);
  return walk;
}

// Heading of the route itself, radians, continuous along the walk: each
// corner adds a quarter turn spread over kCornerBlend either side of it.
double route_heading(const Walk& walk, double w) {
  double heading = 0;
  for (const double c : walk.corner) {
    heading += 0.5 * kPi * ramp((w - c + kCornerBlend) / (2 * kCornerBlend));
  }
  return heading;
}

// `angle` plus the whole turns that bring it within half a turn of `near`.
double unwrap_near(double angle, double near) {
  return near + std::remainder(angle - near, 2 * kPi);
}

// The point of the block's facade along leg k, `along` metres from the
// leg's start, kept half a metre in from the facade's ends (which stop
// `inner` short of the route's corners).
Eigen::Vector2d facade_point(const Layout& layout, int k, double along) {
  const Route& route = layout.route;
  along = std::clamp(along, layout.inner + 0.5,
                     route.length(k) - layout.inner - 0.5);
  return route.origin(k) + along * route.direction(k) +
         layout.inner * route.left(k);
}

// The bearing from the walker at arc length s to the block's facade `lead`
// metres ahead. Past the block's corner it swings over to the facade round
// the corner: both facades are then in view and the block is convex, so
// every heading between the two targets meets it, rather than looking past
// its corner down the next street.
double block_bearing(const Layout& layout, double s, double lead) {
  const Route& route = layout.route;
  const int k = route.leg(s);
  const double t = route.wrap(s) - route.start(k);
  const double length = route.length(k);
  const Eigen::Vector2d p = route.point(s);
  const auto bearing = [&](const Eigen::Vector2d& target) {
    const Eigen::Vector2d d = target - p;
    return std::atan2(d.y(), d.x());
  };
  const double here = bearing(facade_point(layout, k, t + lead));
  const double round =
      ramp((t - (length - layout.inner - 1)) / (layout.inner + 1));
  if (round == 0) return here;
  const double there = unwrap_near(
      bearing(facade_point(layout, (k + 1) % 4, t - length + lead)), here);
  return here + round * (there - here);
}

// The heading the walker aims for, radians from the local x axis,
// continuous along the walk (it ends a turn lower than the route's, after
// the clockwise turn back). Towards the block they aim at its facade a few
// metres ahead (block_bearing), so that they keep it in view even round a
// single building.
double aimed_heading(const Walk& walk, double w) {
  const double p = walk.perimeter();
  const auto wobble = [&](int i) {
    return std::sin(2 * kPi * walk.wobble_cycles[i] * w / p +
                    walk.wobble_phase[i]);
  };
  const Layout& layout = walk.layout;
  const double s = walk.arc(w);
  const double route = route_heading(walk, w);
  const double left =
      unwrap_near(block_bearing(layout, s, 2.8 + 0.8 * wobble(0)), route) -
      route;
  const double right = -radians(walk.right_deg + 8 * wobble(1));
  const double to_right =
      ramp((w - walk.ne() + kCornerBlend) / (2 * kCornerBlend));
  const double back = ramp((w - walk.back_start()) / walk.back_len);
  const double relative =
      (1 - back) * ((1 - to_right) * left + to_right * right) +
      back * (left - 2 * kPi);
  const double sweep =
      walk.sweep_deg *
      std::max(0.0, 1 - std::abs(w - walk.ne()) / walk.sweep_half);
  return route + relative - radians(sweep);
}

// Relative walking speed: the walker slows down to turn, so that photos
// stay close in heading.
double speed(const Walk& walk, double w) {
  double v = 1;
  for (const double c : walk.corner) {
    if (std::abs(w - c) < kCornerBlend + 0.5) v = std::min(v, 0.7);
  }
  if (w > walk.back_start() - 0.5 && w < walk.back_end()) v = std::min(v, 0.5);
  if (walk.sweep_deg > 0 && std::abs(w - walk.ne()) < walk.sweep_half) {
    v = std::min(v, 0.5);
  }
  return v;
}

// No burst where the heading already turns, nor next to a gateway.
bool calm(const Walk& walk, double w) {
  for (const double c : walk.corner) {
    if (std::abs(w - c) < kCornerBlend + 1) return false;
  }
  if (walk.sweep_deg > 0 && std::abs(w - walk.ne()) < walk.sweep_half + 1) {
    return false;
  }
  if (w > walk.back_start() - 1 && w < walk.back_end() + 2) return false;
  for (const double gate : {walk.layout.gate_in, walk.layout.gate_out}) {
    const double g = walk.layout.route.wrap(gate - walk.start);
    if (std::abs(w - g) < 2.5) return false;
  }
  return true;
}

// `stops` positions along the walk (w), the first at 0, with steps drawn
// from 0.85-1.15 times a base length scaled by the local speed, and the
// step from the last stop back to the first of the same kind: the loop
// closes.
std::vector<double> stop_positions(const Walk& walk, int stops,
                                   SplitMix64& rng) {
  // Walk time as a function of w, tabulated every 2 cm.
  const double p = walk.perimeter();
  const double h = 0.02;
  const int n = static_cast<int>(std::ceil(p / h));
  std::vector<double> time(n + 1, 0);
  for (int i = 0; i < n; ++i) {
    const double w0 = i * h, w1 = std::min(p, w0 + h);
    time[i + 1] = time[i] + (w1 - w0) / speed(walk, 0.5 * (w0 + w1));
  }
  std::vector<double> gaps(stops);
  double total = 0;
  for (double& gap : gaps) total += gap = rng.uniform(0.85, 1.15);
  std::vector<double> positions;
  double elapsed = 0;
  for (int j = 0; j < stops; ++j) {
    const auto it = std::lower_bound(time.begin(), time.end(), elapsed);
    const int i = std::max(1, static_cast<int>(it - time.begin()));
    const double f = (elapsed - time[i - 1]) / (time[i] - time[i - 1]);
    positions.push_back(std::min(p, (i - 1 + f) * h));
    elapsed += gaps[j] / total * time[n];
  }
  positions[0] = 0;
  return positions;
}

// The number of photos at each stop: 1, or the next of the burst `sizes`
// at a calm stop, the bursts spread evenly along the walk and never at
// neighbouring stops.
std::vector<int> place_bursts(const Walk& walk,
                              const std::vector<double>& positions,
                              const std::vector<int>& sizes, SplitMix64& rng) {
  const int stops = static_cast<int>(positions.size());
  const int count = static_cast<int>(sizes.size());
  std::vector<int> per_stop(stops, 1);
  const auto free = [&](int j) {
    return j >= 2 && j < stops - 3 && per_stop[j] == 1 &&
           per_stop[j - 1] == 1 && per_stop[j + 1] == 1;
  };
  for (int b = 0; b < count; ++b) {
    const int target =
        static_cast<int>((b + 0.5 + rng.uniform(-0.3, 0.3)) * stops / count);
    int chosen = -1;
    for (int d = 0; d < stops && chosen < 0; ++d) {
      for (const int j : {target + d, target - d}) {
        if (j >= 0 && j < stops && free(j) && calm(walk, positions[j])) {
          chosen = j;
          break;
        }
      }
    }
    // No calm stop left: any free one keeps the photo count.
    for (int j = 0; chosen < 0 && j < stops; ++j) {
      if (free(j)) chosen = j;
    }
    // The caller leaves at least four stops per burst, so one is free.
    if (chosen < 0) throw std::logic_error("block_scene: no stop for a burst");
    per_stop[chosen] = sizes[b];
  }
  return per_stop;
}

struct Shot {
  Eigen::Vector3d centre;
  double yaw = 0;    // radians from the local x axis, counterclockwise
  double pitch = 0;  // radians, negative down
};

// The photos in walking order. A stop's heading follows aimed_heading()
// but turns at most 12 degrees from the previous photo's; a burst then
// keeps turning away from straight ahead, 8-12 degrees a photo.
std::vector<Shot> walk_shots(const Walk& walk, int views, SplitMix64& rng) {
  std::vector<int> sizes(views >= 30 ? views / 16 : 0);
  int extra = 0;
  for (int& size : sizes) extra += (size = rng.integer(3, 5)) - 1;
  const int stops = views - extra;
  const std::vector<double> positions = stop_positions(walk, stops, rng);
  const std::vector<int> per_stop = place_bursts(walk, positions, sizes, rng);
  const double max_turn = radians(12);
  double yaw = aimed_heading(walk, 0);
  std::vector<Shot> shots;
  for (int j = 0; j < stops; ++j) {
    const double w = positions[j];
    const Eigen::Vector2d ground = walk.layout.route.point(walk.arc(w));
    const double aimed = aimed_heading(walk, w);
    yaw += std::clamp(aimed - yaw, -max_turn, max_turn);
    // Away from straight ahead: further round towards the wall in view.
    const double away =
        std::remainder(aimed - route_heading(walk, w), 2 * kPi) >= 0 ? 1 : -1;
    const double turn = away * radians(rng.uniform(8, 12));
    const Eigen::Vector3d centre(ground.x(), ground.y(),
                                 rng.uniform(1.55, 1.65));
    for (int i = 0; i < per_stop[j]; ++i) {
      Shot shot{centre, yaw, radians(walk.pitch_deg + rng.uniform(-0.3, 0.3))};
      if (i > 0) {
        // A hand-held camera does not turn about its exact centre.
        for (int axis = 0; axis < 3; ++axis) {
          shot.centre[axis] += rng.uniform(-0.015, 0.015);
        }
        shot.yaw = yaw += turn;
      }
      shots.push_back(shot);
    }
  }
  return shots;
}

}  // namespace

BlockScene block_scene(uint32_t seed, int views, cv::Size size,
                       double focal_px) {
  if (views < 2) {
    throw std::invalid_argument("block_scene: views must be at least 2");
  }
  if (size.width <= 0 || size.height <= 0) {
    throw std::invalid_argument("block_scene: empty image size");
  }
  SplitMix64 rng(seed);
  const Layout layout = make_layout(rng, views);
  BlockScene scene;
  scene.site = make_site(layout, rng);
  const Walk walk = make_walk(layout, views, rng);
  const std::vector<Shot> shots = walk_shots(walk, views, rng);

  // Local frame to world: turn about the route's centre, which becomes the
  // origin.
  const double heading = rng.uniform(0, 2 * kPi);
  const Eigen::Matrix3d turn =
      Eigen::AngleAxisd(heading, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Vector3d centre(0.5 * layout.route.a, 0.5 * layout.route.b, 0);
  for (Quad& quad : scene.site.quads) {
    quad.corner = turn * (quad.corner - centre);
    quad.edge_u = turn * quad.edge_u;
    quad.edge_v = turn * quad.edge_v;
  }
  Eigen::Matrix3d K;
  K << focal_px, 0, (size.width - 1) / 2.0, 0, focal_px,
      (size.height - 1) / 2.0, 0, 0, 1;
  for (const Shot& shot : shots) {
    const Eigen::Vector3d forward(std::cos(shot.yaw) * std::cos(shot.pitch),
                                  std::sin(shot.yaw) * std::cos(shot.pitch),
                                  std::sin(shot.pitch));
    const Eigen::Vector3d eye = turn * (shot.centre - centre);
    scene.views.push_back(look_at(eye, eye + 10 * (turn * forward), K, size));
  }
  return scene;
}

std::string strecha_camera(const PinholeView& view) {
  std::ostringstream out;
  out.precision(17);
  const auto row = [&](const auto& r) {
    out << r(0) << " " << r(1) << " " << r(2) << "\n";
  };
  for (int i = 0; i < 3; ++i) row(view.K.row(i));
  out << "0 0 0\n";
  const Eigen::Matrix3d camera_to_world = view.R.transpose();
  for (int i = 0; i < 3; ++i) row(camera_to_world.row(i));
  row(view.centre());
  out << view.size.width << " " << view.size.height << "\n";
  return out.str();
}

}  // namespace arscout::engine::synthetic
