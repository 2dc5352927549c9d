#include "rendered_street.h"

#include <map>
#include <mutex>
#include <random>
#include <stdexcept>
#include <utility>

#include <Eigen/Geometry>
#include <opencv2/imgcodecs.hpp>

namespace arscout::engine::street_fixture {

const synthetic::Site& street_scene() {
  static const synthetic::Site site = synthetic::street_site(kStreetSeed);
  return site;
}

const std::vector<Rendered>& rendered_street(cv::Size size) {
  static std::mutex mutex;
  static std::map<std::pair<int, int>, std::vector<Rendered>> by_size;
  const std::lock_guard lock(mutex);
  auto [it, added] = by_size.try_emplace({size.width, size.height});
  if (added) {
    const double focal = 560.0 * size.width / 640.0;
    for (const auto& view :
         synthetic::street_cameras(kStreetViews, size, focal))
      it->second.push_back({view, synthetic::render(street_scene(), view)});
  }
  return it->second;
}

std::string view_id(int index) { return "view" + std::to_string(index); }

ReconstructionOptions street_options() {
  ReconstructionOptions o;
  o.deterministic = true;
  o.long_side = 320;
  return o;
}

std::vector<CaptureInput> street_captures(cv::Size size) {
  const std::vector<Rendered>& street = rendered_street(size);
  std::vector<CaptureInput> result;
  for (int i = 0; i < kStreetViews; ++i) {
    std::vector<uchar> png;
    if (!cv::imencode(".png", street[i].image.bgr, png))
      throw std::runtime_error("PNG encoding failed");
    CaptureInput input;
    input.id = view_id(i);
    input.image_bytes.assign(png.begin(), png.end());
    const Eigen::Matrix3d& k = street[i].view.K;
    input.camera =
        centred_camera(size.width, size.height, k(0, 0), "calibrated");
    input.camera->cx = k(0, 2);
    input.camera->cy = k(1, 2);
    input.camera_id = "street";
    result.push_back(std::move(input));
  }
  return result;
}

Eigen::Vector3d surface_point(const Rendered& r, int x, int y) {
  const double z = r.image.depth.at<float>(y, x);
  const Eigen::Vector3d ray = r.view.K.inverse() * Eigen::Vector3d(x, y, 1);
  return r.view.R.transpose() * (z * ray - r.view.t);
}

std::vector<Eigen::Vector3d> sample_surface(const Rendered& r, int count,
                                            std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> px(0, r.view.size.width - 1);
  std::uniform_int_distribution<int> py(0, r.view.size.height - 1);
  std::vector<Eigen::Vector3d> points;
  while (static_cast<int>(points.size()) < count) {
    const int x = px(rng), y = py(rng);
    if (r.image.depth.at<float>(y, x) <= 0) continue;
    points.push_back(surface_point(r, x, y));
  }
  return points;
}

std::optional<Eigen::Vector2d> seen_at(const Rendered& r,
                                       const Eigen::Vector3d& X, int border) {
  const Eigen::Vector3d c = r.view.R * X + r.view.t;
  if (c.z() <= 0) return std::nullopt;
  const Eigen::Vector3d p = r.view.K * c;
  const Eigen::Vector2d pixel = p.head<2>() / p.z();
  const int u = static_cast<int>(std::lround(pixel.x()));
  const int v = static_cast<int>(std::lround(pixel.y()));
  if (u < border || v < border || u >= r.view.size.width - border ||
      v >= r.view.size.height - border)
    return std::nullopt;
  const float z = r.image.depth.at<float>(v, u);
  if (z <= 0 || std::abs(z - c.z()) > 0.01 * c.z()) return std::nullopt;
  return pixel;
}

DenseView dense_view(const Rendered& r, const std::string& id,
                     std::vector<Eigen::Vector3d> sparse) {
  DenseView v;
  v.id = id;
  v.bgr = r.image.bgr;
  v.K = r.view.K;
  v.R = r.view.R;
  v.t = r.view.t;
  v.sparse_points = std::move(sparse);
  return v;
}

SparseTruth sparse_truth(const std::vector<Rendered>& street, int count,
                         std::uint32_t seed) {
  const cv::Size size = street.front().view.size;
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> pick(0,
                                          static_cast<int>(street.size()) - 1);
  std::uniform_int_distribution<int> px(4, size.width - 5);
  std::uniform_int_distribution<int> py(4, size.height - 5);
  SparseTruth truth;
  while (static_cast<int>(truth.points.size()) < count) {
    const Rendered& r = street[pick(rng)];
    const int x = px(rng), y = py(rng);
    if (r.image.depth.at<float>(y, x) <= 0) continue;
    const Eigen::Vector3d X = surface_point(r, x, y);
    std::vector<std::optional<Eigen::Vector2d>> seen;
    int views = 0;
    for (const Rendered& v : street) {
      seen.push_back(seen_at(v, X, 4));
      if (seen.back()) ++views;
    }
    if (views < 3) continue;
    truth.points.push_back(X);
    truth.seen.push_back(std::move(seen));
  }
  return truth;
}

namespace {

ModelCamera street_camera(const Rendered& r) {
  ModelCamera camera;
  camera.id = "street";
  const Eigen::Matrix3d& K = r.view.K;
  camera.intrinsics.width = r.view.size.width;
  camera.intrinsics.height = r.view.size.height;
  camera.intrinsics.fx = K(0, 0);
  camera.intrinsics.fy = K(1, 1);
  camera.intrinsics.cx = K(0, 2);
  camera.intrinsics.cy = K(1, 2);
  camera.intrinsics.source = "calibrated";
  return camera;
}

ModelImage posed_image(const Rendered& r, const std::string& id) {
  ModelImage image;
  image.id = id;
  image.camera = 0;
  const Eigen::Quaterniond q(r.view.R);
  image.qvec = {q.w(), q.x(), q.y(), q.z()};
  image.tvec = {r.view.t.x(), r.view.t.y(), r.view.t.z()};
  const Eigen::Vector3d c = r.view.centre();
  image.centre = {c.x(), c.y(), c.z()};
  image.keypoints.push_back({1.0, 1.0});  // unmatched
  image.point_ids.push_back(-1);
  return image;
}

}  // namespace

Model build_model(const std::vector<Rendered>& street, const SparseTruth& truth,
                  const std::vector<int>& views) {
  Model model;
  model.cameras.push_back(street_camera(street.front()));
  for (int v : views)
    model.images.push_back(posed_image(street[v], view_id(v)));
  for (size_t p = 0; p < truth.points.size(); ++p) {
    int observations = 0;
    for (int v : views)
      if (truth.seen[p][v]) ++observations;
    if (observations < 2) continue;
    ModelPoint point;
    point.id = 1000 + static_cast<int64_t>(p);
    point.xyz = {truth.points[p].x(), truth.points[p].y(), truth.points[p].z()};
    point.rgb = {128, 128, 128};
    for (size_t i = 0; i < views.size(); ++i) {
      const auto& pixel = truth.seen[p][views[i]];
      if (!pixel) continue;
      ModelImage& image = model.images[i];
      point.track.emplace_back(static_cast<int>(i),
                               static_cast<int>(image.keypoints.size()));
      image.keypoints.push_back({pixel->x(), pixel->y()});
      image.point_ids.push_back(point.id);
    }
    model.points.push_back(std::move(point));
  }
  return model;
}

}  // namespace arscout::engine::street_fixture
