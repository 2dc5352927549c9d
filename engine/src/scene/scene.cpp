#include "scene/scene.h"

#include <algorithm>

namespace arscout::engine {

int Scene::registered_count() const {
  return static_cast<int>(
      std::count_if(images.begin(), images.end(),
                    [](const SceneImage& image) { return image.registered; }));
}

std::map<int, int> Scene::component_sizes() const {
  std::map<int, int> sizes;
  for (const SceneImage& image : images)
    if (image.registered) ++sizes[image.component];
  return sizes;
}

int Scene::component_of_point(int64_t id) const {
  const ScenePoint& point = points.at(id);
  return point.track.empty() ? -1 : images[point.track.front().image].component;
}

int Scene::find_image(const std::string& id) const {
  for (size_t i = 0; i < images.size(); ++i) {
    if (!images[i].removed && images[i].id == id) return static_cast<int>(i);
  }
  return -1;
}

const ImagePair* Scene::pair(int a, int b) const {
  auto it = pairs.find({std::min(a, b), std::max(a, b)});
  return it == pairs.end() ? nullptr : &it->second;
}

std::vector<std::pair<int, const ImagePair*>> Scene::pairs_of(int image) const {
  std::vector<std::pair<int, const ImagePair*>> result;
  for (const auto& [key, pair] : pairs) {
    if (key.first == image) result.emplace_back(key.second, &pair);
    if (key.second == image) result.emplace_back(key.first, &pair);
  }
  return result;
}

std::vector<std::pair<int, int>> oriented_matches(int image, int other,
                                                  const ImagePair& pair) {
  if (image < other) return pair.matches;
  std::vector<std::pair<int, int>> flipped;
  flipped.reserve(pair.matches.size());
  for (const auto& [a, b] : pair.matches) flipped.emplace_back(b, a);
  return flipped;
}

void Scene::remove_point(int64_t id) {
  auto it = points.find(id);
  if (it == points.end()) return;
  for (const Observation& obs : it->second.track) {
    images[obs.image].point_of[obs.keypoint] = -1;
  }
  points.erase(it);
}

void Scene::merge_points(int64_t keep, int64_t gone,
                         const Eigen::Vector3d& xyz) {
  ScenePoint& kept = points.at(keep);
  for (const Observation& obs : points.at(gone).track) {
    kept.track.push_back(obs);
    images[obs.image].point_of[obs.keypoint] = keep;
  }
  kept.xyz = xyz;
  points.erase(gone);
}

void Scene::add_observation(int64_t point, Observation obs) {
  points.at(point).track.push_back(obs);
  images[obs.image].point_of[obs.keypoint] = point;
}

void Scene::remove_observation(Observation obs) {
  int64_t& point_of = images[obs.image].point_of[obs.keypoint];
  const int64_t id = point_of;
  if (id < 0) return;
  point_of = -1;
  std::vector<Observation>& track = points.at(id).track;
  std::erase(track, obs);
  if (track.size() < 2) remove_point(id);
}

int64_t Scene::add_point(const Eigen::Vector3d& xyz,
                         const std::vector<Observation>& track) {
  const int64_t id = next_point_id++;
  ScenePoint& point = points[id];
  point.xyz = xyz;
  const Observation& first = track.front();
  point.rgb = images[first.image].colors[first.keypoint];
  for (const Observation& obs : track) add_observation(id, obs);
  return id;
}

bool project(const SceneCamera& camera, const SceneImage& image,
             const Eigen::Vector3d& world, Eigen::Vector2d* pixel) {
  const Eigen::Vector3d p = image.q * world + image.t;
  if (p.z() <= 1e-9) return false;
  const double x = p.x() / p.z();
  const double y = p.y() / p.z();
  const auto& k = camera.params;
  const double r2 = x * x + y * y;
  const double d = 1 + k[4] * r2 + k[5] * r2 * r2;
  *pixel = {k[0] * d * x + k[2], k[1] * d * y + k[3]};
  return true;
}

double mean_reprojection_px(const Scene& scene) {
  double sum = 0;
  size_t count = 0;
  for (const auto& [id, point] : scene.points) {
    for (const Observation& obs : point.track) {
      const SceneImage& image = scene.images[obs.image];
      Eigen::Vector2d projected;
      if (!project(scene.cameras[image.camera], image, point.xyz, &projected))
        continue;
      sum += (projected - image.keypoints[obs.keypoint]).norm();
      ++count;
    }
  }
  return count ? sum / count : 0;
}

Eigen::Vector2d normalize(const SceneCamera& camera,
                          const Eigen::Vector2d& px) {
  const auto& k = camera.params;
  const Eigen::Vector2d distorted((px.x() - k[2]) / k[0],
                                  (px.y() - k[3]) / k[1]);
  Eigen::Vector2d x = distorted;
  if (k[4] == 0 && k[5] == 0) return x;
  for (int i = 0; i < 20; ++i) {
    const double r2 = x.squaredNorm();
    x = distorted / (1 + k[4] * r2 + k[5] * r2 * r2);
  }
  return x;
}

}  // namespace arscout::engine
