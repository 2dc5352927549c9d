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

#include <cmath>
#include <cstdint>
#include <string>
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

// splitmix64 (Steele, Lea and Flood, 2014): a tiny generator whose output
// is fixed by its arithmetic alone. The scenes and the simulated GPS draw
// from it rather than from std:: distributions, whose algorithms differ
// between standard libraries, so a seed gives the same site everywhere.
class SplitMix64 {
 public:
  explicit SplitMix64(uint64_t seed) : state_(seed) {}

  uint64_t next() {
    uint64_t z = (state_ += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
  }
  // Uniform in [0, 1), 53 bits.
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
  double uniform(double low, double high) {
    return low + (high - low) * uniform();
  }
  // Uniform in [low, high]; the modulo bias is far below anything a scene
  // could show.
  int integer(int low, int high) {
    return low +
           static_cast<int>(next() % static_cast<uint64_t>(high - low + 1));
  }
  // Standard normal by Box-Muller, one value per call (the sine twin is
  // dropped so that every draw takes exactly two uniforms).
  double gaussian() {
    const double radius = std::sqrt(-2 * std::log(1 - uniform()));
    return radius * std::cos(6.283185307179586 * uniform());
  }

 private:
  uint64_t state_;
};

// A scale scene with exact ground truth: a scout's loop walk round a city
// block, with the layout generated to fit the walk.
//
// The route is a rectangle whose perimeter follows `views` (about 0.85 m of
// walk per photo, at least 56 m), walked counterclockwise with the block on the
// walker's left. The inner block (one building for a small loop, a row of slabs
// or a ring of buildings for larger ones) stands 4-5.5 m from the route, an
// outer ring of buildings faces it from the other side 5-7.5 m away (the narrow
// ends of both ranges for small loops). Buildings are boxes of four walls and a
// roof, 6-25 m along the street and 5-15 m high; most faces are value noise,
// each face with a seed of its own; some faces under 12 m wide are plaster
// (fainter), a few under 10 m brick (bricks repeat, which misleads feature
// matching where they fill a view); the ground is asphalt. Where the route
// rounds the block's north-east corner (in the route's own frame) it runs
// through a courtyard: walls 4-6 m high with 6 m gateways cross the street on
// either side of the corner (the second on the north leg, or for a short block
// on the west leg, putting the whole north side in the courtyard), and the
// courtyard's outer walls stand 1-2.5 m further back than the street's.
//
// The walker looks at the block a few metres ahead on their left; in the
// courtyard they turn to its outer walls, sweeping up to 150 degrees further
// round about the corner when there are photos to spare (0.5 degrees per view
// beyond 60), keep to the outer row along the north leg and turn back to the
// block, clockwise, after the north-west corner. Views are in walking order and
// make a closed loop: consecutive photos 0.3-2 m apart (denser while turning),
// 1.55-1.65 m high, level (no roll; pitch 5-6 degrees down, so the ground fills
// the bottom of the frame and the optical axis meets a surface within 19 m even
// across a crossing), headings changing by at most 12 degrees from photo to
// photo, every photo at least 2.9 m from every wall. One photo in 16 or so
// starts a burst of 3-5 photos from one spot (within 2 cm) turning 8-12 degrees
// between them. The last photo is taken about one step before the first and
// looks at the same facade. The principal point is at the image centre
// ((width - 1) / 2, (height - 1) / 2), the focal length `focal_px`; the walk
// does not depend on the image size.
//
// The seed changes the layout (proportions, street widths, buildings,
// courtyard, the whole scene's heading about the vertical), the walk (start,
// steps, bursts, headings) and the textures. The world frame is east-north-up
// with the route's centre at the origin. Below about 55 views the smallest loop
// forces steps over 2 m. Throws std::invalid_argument when views < 2 or the
// size is empty.
struct BlockScene {
  Site site;
  std::vector<PinholeView> views;  // in walking order
};
BlockScene block_scene(uint32_t seed, int views, cv::Size size = {1024, 768},
                       double focal_px = 896);

// The view as a Strecha ground-truth `.camera` file (../shared/data/
// README.md): K, a row of zero distortion, R camera-to-world (the transpose
// of view.R), the centre, then "width height", with 17 significant digits
// so that a reader gets the view back to double precision.
std::string strecha_camera(const PinholeView& view);

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

// How many of the view's rays, through every step_px-th pixel each way,
// meet each quad of `site` first (indexed like Site::quads): what the view
// sees, occlusion included, at a cost of a few thousand rays. Throws
// std::invalid_argument when step_px < 1.
std::vector<int> quads_seen(const Site& site, const PinholeView& view,
                            int step_px = 8);

// The block scene with one facade that no photo sees (render-site
// --leave-unseen, the coverage guidance's test). On a small loop (60-80
// views) the walk goes round one building; of its walls at least
// min_width_m wide, the one that the shortest stretch of the walk looks at
// (views whose quads_seen rays meet it for a tenth or more; a view that
// catches it at a grazing angle does not count), and that stretch: leaving
// it out leaves one walk that sees the building's other sides. Throws
// std::invalid_argument when no building stands over the route's centre.
struct UnseenWall {
  int quad = -1;              // in Site::quads
  std::vector<bool> seen_by;  // per view: in the stretch left out
  Eigen::Vector3d from, to;   // its bottom edge, world frame
  double facing_deg = 0;      // compass bearing of its outward side
};
UnseenWall unseen_inner_wall(const BlockScene& scene, double min_width_m = 5);

// The albedo of `texture` at metric texture coordinates (u, v), BGR in
// [0, 1], before the quad's brightness is applied. Exposed so that tests
// and demos can reason about the pattern without rendering.
cv::Vec3f texture_colour(Texture texture, uint32_t seed, double u, double v);

}  // namespace arscout::engine::synthetic
