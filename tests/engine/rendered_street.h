// The rendered street of the dense tests (synthetic_site.h): five
// converging views of street_site(3) with each pixel's exact depth,
// rendered once per image size, and the ground-truth geometry the tests
// measure against (surface points, visibility, sparse models with exact
// poses and keypoints).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "arscout/engine/dense.h"
#include "arscout/engine/reconstruction.h"
#include "arscout/engine/synthetic_site.h"

namespace arscout::engine::street_fixture {

constexpr int kStreetViews = 5;
constexpr std::uint32_t kStreetSeed = 3;

struct Rendered {
  synthetic::PinholeView view;
  synthetic::Rendering image;
};

// street_site(kStreetSeed), built once.
const synthetic::Site& street_scene();
// The kStreetViews views at `size`, focal length 560 px per 640 px of
// width, rendered once per size and kept for the whole test run.
const std::vector<Rendered>& rendered_street(cv::Size size);

// "view<index>": the id the tests give view `index`.
std::string view_id(int index);
// The views at `size` as captures: PNG bytes, the exact intrinsics, one
// camera ("street"), no fixes.
std::vector<CaptureInput> street_captures(cv::Size size);
// Deterministic reconstruction at a long side of 320 px, for the captures
// of street_captures({320, 240}).
ReconstructionOptions street_options();

// The world point seen at pixel (x, y) of `r`, at its true depth.
Eigen::Vector3d surface_point(const Rendered& r, int x, int y);
// `count` surface points seen by `r` at random pixels (fixed `seed`), as
// a sparse reconstruction would have them.
std::vector<Eigen::Vector3d> sample_surface(const Rendered& r, int count,
                                            std::uint32_t seed);
// Where `r` sees world point X: in front, at least `border` pixels inside
// the image and not hidden (the rendered depth there within 1 %).
std::optional<Eigen::Vector2d> seen_at(const Rendered& r,
                                       const Eigen::Vector3d& X, int border);
// `r` as the dense stages take a view, with `sparse` as its sparse points.
DenseView dense_view(const Rendered& r, const std::string& id,
                     std::vector<Eigen::Vector3d> sparse);

// Surface points with where each view sees them (nullopt where it does not).
struct SparseTruth {
  std::vector<Eigen::Vector3d> points;
  std::vector<std::vector<std::optional<Eigen::Vector2d>>> seen;
};
// `count` surface points of `street`, each seen by at least three views
// (4 pixels inside), drawn with a fixed `seed`.
SparseTruth sparse_truth(const std::vector<Rendered>& street, int count,
                         std::uint32_t seed);
// The sparse model of `views` (indices into `street`, in this order): exact
// poses and intrinsics (one camera, "street"), the points seen by at least
// two of them, keypoints at their exact projections, and one unmatched
// keypoint per image, as real images have.
Model build_model(const std::vector<Rendered>& street, const SparseTruth& truth,
                  const std::vector<int>& views);

}  // namespace arscout::engine::street_fixture
