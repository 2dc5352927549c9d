// Procedural textures for the synthetic site. Everything is lattice value
// noise over an integer hash, so a texel depends on (texture, seed, u, v)
// alone: no state, no tables, and the same colour in every view and run.
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "arscout/engine/synthetic_site.h"

namespace arscout::engine::synthetic {
namespace {

// An avalanching 32-bit mix: flipping any input bit flips about half of the
// output bits, so neighbouring lattice cells and consecutive seeds get
// unrelated values.
uint32_t mix32(uint32_t x) {
  x ^= x >> 16;
  x *= 0x21f0aaadu;
  x ^= x >> 15;
  x *= 0x735a2d97u;
  x ^= x >> 15;
  return x;
}

// One mix per lattice value keeps the noise cheap; the odd multipliers
// spread the cells so that distinct (i, j) only collide 2^32 cells apart,
// far beyond any site.
uint32_t cell_hash(int64_t i, int64_t j, uint32_t salt) {
  return mix32(static_cast<uint32_t>(i) * 0x8da6b343u +
               static_cast<uint32_t>(j) * 0xd8163841u + salt);
}

// The top 24 bits as a float in [0, 1): exact, and enough resolution for 8-bit
// output.
double unit(uint32_t hash) { return (hash >> 8) * (1.0 / 16777216.0); }

// Independent noise streams per texture channel, so e.g. brick grain does
// not repeat the per-brick tone pattern.
uint32_t stream(uint32_t seed, uint32_t channel) {
  return mix32(seed * 0x9e3779b9u + channel);
}

// Smoothstep weights hide the lattice (no kinks at cell borders) without the
// cost of a gradient noise.
double smooth(double f) { return f * f * (3 - 2 * f); }

// std::floor is a library call on baseline x86-64 (no SSE4.1 rounding) and
// dominated the render time; truncation plus a fix-up is exact for the
// coordinate range of any site.
int64_t floor_int(double x) {
  const auto truncated = static_cast<int64_t>(x);
  return x < static_cast<double>(truncated) ? truncated - 1 : truncated;
}

// Value noise with unit lattice spacing, in [0, 1).
double value_noise(double x, double y, uint32_t salt) {
  const int64_t i = floor_int(x);
  const int64_t j = floor_int(y);
  const double sx = smooth(x - static_cast<double>(i));
  const double sy = smooth(y - static_cast<double>(j));
  const double v00 = unit(cell_hash(i, j, salt));
  const double v10 = unit(cell_hash(i + 1, j, salt));
  const double v01 = unit(cell_hash(i, j + 1, salt));
  const double v11 = unit(cell_hash(i + 1, j + 1, salt));
  const double bottom = v00 + sx * (v10 - v00);
  const double top = v01 + sx * (v11 - v01);
  return bottom + sy * (top - bottom);
}

// Measured standard deviation of value_noise over the plane; dividing by it
// makes the amplitudes below standard deviations.
constexpr double kValueNoiseStd = 0.215;

// Zero-mean noise of about unit standard deviation: `octaves` equal-weight
// octaves from wavelength `longest_m` down, halving each time. Equal weights
// keep the finest octaves (the 1-2 cm a matching window sees) as strong as
// the coarse ones. Each octave is shifted so lattice lines never line up.
double octave_noise(double u, double v, uint32_t salt, double longest_m,
                    int octaves) {
  double sum = 0;
  double frequency = 1 / longest_m;
  for (int k = 0; k < octaves; ++k) {
    const uint32_t octave_salt = mix32(salt + static_cast<uint32_t>(k));
    sum += value_noise(u * frequency + 0.37 * k, v * frequency + 0.71 * k,
                       octave_salt) -
           0.5;
    frequency *= 2;
  }
  return sum / (kValueNoiseStd * std::sqrt(static_cast<double>(octaves)));
}

cv::Vec3f clamped(double b, double g, double r) {
  return {static_cast<float>(std::clamp(b, 0.0, 1.0)),
          static_cast<float>(std::clamp(g, 0.0, 1.0)),
          static_cast<float>(std::clamp(r, 0.0, 1.0))};
}

constexpr double kBrickLength = 0.215;
constexpr double kBrickHeight = 0.065;
constexpr double kMortar = 0.01;

// Running bond: each course is shifted by half a brick. The mortar joint
// sits at the start of each brick cell, below and left of the brick.
cv::Vec3f brick(uint32_t seed, double u, double v) {
  constexpr double kCoursePitch = kBrickHeight + kMortar;
  constexpr double kBrickPitch = kBrickLength + kMortar;
  const int64_t course = floor_int(v / kCoursePitch);
  const bool odd = (course & 1) != 0;
  const double along = u + (odd ? kBrickPitch / 2 : 0.0);
  const int64_t column = floor_int(along / kBrickPitch);
  const double in_u = along - static_cast<double>(column) * kBrickPitch;
  const double in_v = v - static_cast<double>(course) * kCoursePitch;
  const double grain = octave_noise(u, v, stream(seed, 1), 0.08, 5);
  if (in_u < kMortar || in_v < kMortar) {
    const double grey = 0.70 * (1 + 0.12 * grain);
    return clamped(0.96 * grey, grey, 1.02 * grey);
  }
  // Fired bricks differ in tone and in how red they are.
  const uint32_t h = cell_hash(column, course, stream(seed, 2));
  const double tone = 0.72 + 0.5 * unit(h);
  const double ochre = unit(mix32(h));
  const double shade = tone * (1 + 0.22 * grain);
  return clamped(shade * (0.17 + 0.06 * ochre), shade * (0.26 + 0.12 * ochre),
                 shade * 0.58);
}

// Large soft stains over a fine trowel grain.
cv::Vec3f plaster(uint32_t seed, double u, double v) {
  const double mottle = octave_noise(u, v, stream(seed, 3), 1.0, 3);
  const double grain = octave_noise(u, v, stream(seed, 4), 0.04, 4);
  const double shade = 1 + 0.07 * mottle + 0.16 * grain;
  return clamped(0.74 * shade, 0.82 * shade, 0.88 * shade);
}

// Strong grain from 16 cm down to 5 mm (coarse octaves keep it textured at
// grazing angles), plus light stones of aggregate.
cv::Vec3f asphalt(uint32_t seed, double u, double v) {
  const double grain = octave_noise(u, v, stream(seed, 5), 0.16, 6);
  const double stones =
      std::max(0.0, value_noise(u / 0.012, v / 0.012, stream(seed, 6)) - 0.7);
  const double grey = 0.30 * (1 + 0.3 * grain) + 1.2 * stones;
  return clamped(1.04 * grey, grey, 0.97 * grey);
}

// Each channel its own noise, 32 cm down to 1 cm.
cv::Vec3f coloured_noise(uint32_t seed, double u, double v) {
  auto channel = [&](uint32_t c) {
    return 0.5 + 0.2 * octave_noise(u, v, stream(seed, 7 + c), 0.32, 6);
  };
  return clamped(channel(0), channel(1), channel(2));
}

}  // namespace

cv::Vec3f texture_colour(Texture texture, uint32_t seed, double u, double v) {
  switch (texture) {
    case Texture::kBrick:
      return brick(seed, u, v);
    case Texture::kPlaster:
      return plaster(seed, u, v);
    case Texture::kAsphalt:
      return asphalt(seed, u, v);
    case Texture::kNoise:
      break;
  }
  return coloured_noise(seed, u, v);
}

}  // namespace arscout::engine::synthetic
