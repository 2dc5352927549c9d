// A deterministic renderer of synthetic urban scenes with exact ground truth:
// textured planar quads ray-cast through pinhole cameras. Dense-stereo tests
// check their depth maps against the exact depth it returns, and demos use
// its images as photos of a fake site.
//
// Shading is view-independent on purpose (each quad has one brightness that
// depends on its orientation only, no specular, no shadows): stereo matching
// assumes brightness constancy, so a surface point has the same colour in
// every view, up to anti-aliasing.
//
// Frames: the world is east-north-up (x east, y north, z up), metres. Views
// are world-to-camera with OpenCV camera axes (x right, y down, z forward),
// pixel centres at integer coordinates. Everything is a pure function of its
// arguments: the same call gives bit-identical images on every run.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace arscout::engine::synthetic {

// Procedural textures, deterministic from (texture, seed, u, v), with
// contrast at the 1-2 cm scale so that a 7x7 matching window at ~1.5 cm per
// pixel is well textured.
enum class Texture {
  kBrick,    // running-bond bricks 0.215 x 0.065 m, 0.01 m mortar joints
  kPlaster,  // mottled off-white with fine grain
  kAsphalt,  // dark grey with strong fine grain and light aggregate
  kNoise,    // multi-octave coloured value noise
};

// The planar parallelogram corner + s * edge_u + t * edge_v, s, t in [0, 1],
// seen from both sides. Texture coordinates are metric, (s * |edge_u|,
// t * |edge_v|), so texture scale is physical: bricks are laid along edge_u
// with courses stacked along edge_v. Its brightness follows the direction
// of edge_u x edge_v (up to sign), so differently oriented faces differ.
// Degenerate quads (parallel edges) are never hit.
struct Quad {
  Eigen::Vector3d corner;
  Eigen::Vector3d edge_u;
  Eigen::Vector3d edge_v;
  Texture texture = Texture::kNoise;
  uint32_t seed = 0;  // varies the pattern, not its statistics
};

struct Site {
  std::vector<Quad> quads;
};

// A street scene: a brick facade in the plane y = 10 (x -8..8, z 0..8)
// facing south, asphalt ground z = 0 (x -8..8, y -2..10), a noise-textured
// box of five faces (no bottom) x -1.5..0.5, y 6..7.5, z 0..1.2, and a
// plaster side wall in the plane x = 6 (y 4..10, z 0..6) facing west.
// `seed` changes the texture patterns only, never the geometry. A level,
// north-looking camera 1.6 m high at (1.5, 1) with a 60 degree horizontal
// field of view (640 px at f = 560) sees all four; the converging
// street_cameras() see the facade, the ground and the box but not the wall.
Site street_site(uint32_t seed = 1);

struct PinholeView {
  Eigen::Matrix3d K;  // upper triangular, K(2, 2) = 1
  Eigen::Matrix3d R;  // world to camera: x_cam = R * x_world + t
  Eigen::Vector3d t;
  cv::Size size;

  Eigen::Vector3d centre() const { return -R.transpose() * t; }
};

// The view from `centre` towards `target` with world +z as up: the image x
// axis is horizontal and the image y axis points down in the world. Throws
// std::invalid_argument when the viewing direction is vertical (the roll is
// then undefined) or when centre and target coincide.
PinholeView look_at(const Eigen::Vector3d& centre,
                    const Eigen::Vector3d& target, const Eigen::Matrix3d& K,
                    cv::Size size);

// `count` cameras 1.6 m high on y = 0, evenly spread along x from -2 to 2
// (a single one stands at x = 0), each looking at (0, 10, 2.5) on the facade
// so the views converge. Focal length `focal_px`, principal point at the
// image centre ((width - 1) / 2, (height - 1) / 2). Throws
// std::invalid_argument when count < 1.
std::vector<PinholeView> street_cameras(int count, cv::Size size = {640, 480},
                                        double focal_px = 560);

struct Rendering {
  cv::Mat bgr;    // CV_8UC3
  cv::Mat depth;  // CV_32F: camera z of the surface hit by the ray through
                  // the pixel centre; 0 where the ray hits nothing (sky)
};

// Ray-casts `site` through `view`: each ray takes the colour of the nearest
// quad it hits in front of the camera. A pixel's colour is the mean over
// supersampling x supersampling evenly spread sub-pixel rays (anti-aliasing);
// its depth is not averaged but exact for the ray through its centre (only
// rounded to float). Sky is a plain light blue without texture. Rows are
// rendered in parallel (cv::parallel_for_). Throws std::invalid_argument
// when supersampling < 1 or the size is empty.
Rendering render(const Site& site, const PinholeView& view,
                 int supersampling = 3);

// The albedo of `texture` at metric texture coordinates (u, v), BGR in
// [0, 1], before the quad's brightness is applied. Exposed so that tests
// and demos can reason about the pattern without rendering.
cv::Vec3f texture_colour(Texture texture, uint32_t seed, double u, double v);

}  // namespace arscout::engine::synthetic
