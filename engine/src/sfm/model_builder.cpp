#include "sfm/model_builder.h"

#include <algorithm>
#include <map>

namespace arscout::engine {
namespace {

double to_original(double working, double scale) {
  return (working + 0.5) / scale - 0.5;
}

// Where an undistorted working keypoint lies in the original photo.
std::array<double, 2> original_pixel(const SceneCamera& camera,
                                     const CameraIntrinsics& refined,
                                     const Eigen::Vector2d& keypoint) {
  const Eigen::Vector2d x = normalize(camera, keypoint);
  const double r2 = x.squaredNorm();
  const double radial =
      1 + refined.k1 * r2 + refined.k2 * r2 * r2 + refined.k3 * r2 * r2 * r2;
  const double xd = x.x() * radial + 2 * refined.p1 * x.x() * x.y() +
                    refined.p2 * (r2 + 2 * x.x() * x.x());
  const double yd = x.y() * radial + refined.p1 * (r2 + 2 * x.y() * x.y()) +
                    2 * refined.p2 * x.x() * x.y();
  return {refined.fx * xd + refined.cx, refined.fy * yd + refined.cy};
}

}  // namespace

CameraIntrinsics refined_intrinsics(const SceneCamera& camera) {
  CameraIntrinsics c = camera.original;
  c.fx = camera.params[0] / camera.scale;
  c.fy = camera.params[1] / camera.scale;
  c.cx = to_original(camera.params[2], camera.scale);
  c.cy = to_original(camera.params[3], camera.scale);
  // Radial terms act on normalized coordinates, so they do not depend on
  // the resolution. Exact when only one of the two sets is non-zero.
  c.k1 += camera.params[4];
  c.k2 += camera.params[5];
  return c;
}

namespace {

// The components' sizes, largest first.
std::vector<ModelComponent> components_of(const Model& model) {
  std::map<int, ModelComponent> by_id;
  for (const ModelImage& image : model.images) {
    by_id[image.component].id = image.component;
    ++by_id[image.component].images;
  }
  for (const ModelPoint& point : model.points) {
    if (!point.track.empty())
      ++by_id[model.images[point.track.front().first].component].points;
  }
  std::vector<ModelComponent> result;
  for (const auto& [id, component] : by_id) result.push_back(component);
  std::stable_sort(result.begin(), result.end(),
                   [](const ModelComponent& x, const ModelComponent& y) {
                     return x.images > y.images;
                   });
  return result;
}

}  // namespace

Model build_model(const Scene& scene) {
  Model model;
  model.geo_registered = scene.geo_registered;
  model.enu_origin = scene.enu_origin;
  std::map<int, int> camera_index, image_index;
  std::optional<EnuFrame> frame;
  if (scene.geo_registered && scene.enu_origin)
    frame = EnuFrame(*scene.enu_origin);
  for (size_t i = 0; i < scene.images.size(); ++i) {
    const SceneImage& image = scene.images[i];
    if (!image.registered) continue;
    const SceneCamera& camera = scene.cameras[image.camera];
    if (!camera_index.count(image.camera)) {
      camera_index[image.camera] = static_cast<int>(model.cameras.size());
      model.cameras.push_back({camera.id, refined_intrinsics(camera)});
    }
    const CameraIntrinsics& refined =
        model.cameras[camera_index[image.camera]].intrinsics;
    ModelImage out;
    out.id = image.id;
    out.camera = camera_index[image.camera];
    out.component = image.component;
    out.qvec = {image.q.w(), image.q.x(), image.q.y(), image.q.z()};
    out.tvec = {image.t.x(), image.t.y(), image.t.z()};
    const Eigen::Vector3d c = image.centre();
    out.centre = {c.x(), c.y(), c.z()};
    if (frame) out.geodetic = frame->to_geodetic(out.centre);
    out.keypoints.reserve(image.keypoints.size());
    for (const Eigen::Vector2d& kp : image.keypoints) {
      out.keypoints.push_back(original_pixel(camera, refined, kp));
    }
    out.point_ids = image.point_of;
    image_index[static_cast<int>(i)] = static_cast<int>(model.images.size());
    model.images.push_back(std::move(out));
  }
  double error_sum = 0;
  size_t error_count = 0;
  for (const auto& [id, point] : scene.points) {
    ModelPoint out;
    out.id = id;
    out.xyz = {point.xyz.x(), point.xyz.y(), point.xyz.z()};
    out.rgb = point.rgb;
    double sum = 0;
    for (const Observation& obs : point.track) {
      const SceneImage& image = scene.images[obs.image];
      const SceneCamera& camera = scene.cameras[image.camera];
      Eigen::Vector2d projected;
      if (project(camera, image, point.xyz, &projected)) {
        sum +=
            (projected - image.keypoints[obs.keypoint]).norm() / camera.scale;
      }
      out.track.push_back({image_index.at(obs.image), obs.keypoint});
    }
    out.error_px = point.track.empty() ? 0 : sum / point.track.size();
    error_sum += sum;
    error_count += point.track.size();
    model.points.push_back(std::move(out));
  }
  model.mean_reprojection_px = error_count ? error_sum / error_count : 0;
  model.components = components_of(model);
  return model;
}

}  // namespace arscout::engine
