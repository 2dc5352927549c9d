#include "synthetic_scene.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace arscout::engine::synthetic {

Eigen::Matrix<double, 3, 4> Pose::matrix() const {
  Eigen::Matrix<double, 3, 4> P;
  P << q.toRotationMatrix(), t;
  return P;
}

Pose look_at(const Eigen::Vector3d& centre, const Eigen::Vector3d& target) {
  const Eigen::Vector3d forward = (target - centre).normalized();
  const Eigen::Vector3d right =
      forward.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d down = forward.cross(right);
  Eigen::Matrix3d R;  // rows: the camera axes in world coordinates
  R.row(0) = right.transpose();
  R.row(1) = down.transpose();
  R.row(2) = forward.transpose();
  Pose pose;
  pose.q = Eigen::Quaterniond(R).normalized();
  pose.t = -(pose.q * centre);
  return pose;
}

Truth make_truth(const Layout& layout, std::mt19937& rng) {
  Truth truth;
  const Eigen::Vector3d circle_centre(0, 13, 1.6), target(0, 13, 5);
  for (int i = 0; i < layout.images; ++i) {
    const double fraction =
        layout.images > 1 ? static_cast<double>(i) / (layout.images - 1) : 0.5;
    const double angle = (fraction - 0.5) * layout.arc_deg * M_PI / 180;
    const Eigen::Vector3d centre =
        circle_centre +
        layout.radius_m * Eigen::Vector3d(std::sin(angle), -std::cos(angle), 0);
    truth.poses.push_back(look_at(centre, target));
  }
  std::uniform_real_distribution<double> x(layout.box_min.x(),
                                           layout.box_max.x()),
      y(layout.box_min.y(), layout.box_max.y()),
      z(layout.box_min.z(), layout.box_max.z());
  for (int i = 0; i < layout.points; ++i) {
    const double px = x(rng), py = y(rng), pz = z(rng);
    truth.points.emplace_back(px, py, pz);
  }
  return truth;
}

std::optional<Eigen::Vector2d> project_normalized(
    const Pose& pose, const Eigen::Vector3d& world) {
  const Eigen::Vector3d p = pose.to_camera(world);
  if (p.z() <= 0) return std::nullopt;
  return Eigen::Vector2d(p.x() / p.z(), p.y() / p.z());
}

bool in_image(const Eigen::Vector2d& normalized) {
  const double u = kFocal * normalized.x() + kCx,
               v = kFocal * normalized.y() + kCy;
  return u >= 0 && u <= kWidth - 1 && v >= 0 && v <= kHeight - 1;
}

Eigen::Vector2d random_image_point(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0, kWidth - 1), v(0, kHeight - 1);
  const double pu = u(rng), pv = v(rng);
  return {(pu - kCx) / kFocal, (pv - kCy) / kFocal};
}

Eigen::Vector2d gaussian2(std::mt19937& rng, double sigma) {
  std::normal_distribution<double> n(0, sigma);
  const double a = n(rng), b = n(rng);
  return {a, b};
}

Eigen::Vector3d gaussian3(std::mt19937& rng, double sigma) {
  std::normal_distribution<double> n(0, sigma);
  const double a = n(rng), b = n(rng), c = n(rng);
  return {a, b, c};
}

Eigen::Quaterniond random_rotation(std::mt19937& rng, double angle_deg) {
  const Eigen::Vector3d axis = gaussian3(rng, 1).normalized();
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle_deg * M_PI / 180, axis));
}

TwoView make_two_view(const Truth& truth, int a, int b, double noise_px,
                      double outliers, std::mt19937& rng) {
  TwoView view;
  std::uniform_real_distribution<double> coin(0, 1);
  for (size_t i = 0; i < truth.points.size(); ++i) {
    const auto p1 = project_normalized(truth.poses[a], truth.points[i]);
    const auto p2 = project_normalized(truth.poses[b], truth.points[i]);
    if (!p1 || !p2 || !in_image(*p1) || !in_image(*p2)) continue;
    view.x1.push_back(*p1 + gaussian2(rng, noise_px / kFocal));
    if (coin(rng) < outliers) {
      view.x2.push_back(random_image_point(rng));
      view.outlier.push_back(true);
      view.point.push_back(-1);
    } else {
      view.x2.push_back(*p2 + gaussian2(rng, noise_px / kFocal));
      view.outlier.push_back(false);
      view.point.push_back(static_cast<int>(i));
    }
  }
  return view;
}

Absolute make_absolute(const Truth& truth, int image, double noise_px,
                       double outliers, std::mt19937& rng) {
  Absolute data;
  std::uniform_real_distribution<double> coin(0, 1);
  for (const Eigen::Vector3d& point : truth.points) {
    const auto x = project_normalized(truth.poses[image], point);
    if (!x || !in_image(*x)) continue;
    data.world.push_back(point);
    const bool outlier = coin(rng) < outliers;
    data.image.push_back(
        outlier ? random_image_point(rng)
                : Eigen::Vector2d(*x + gaussian2(rng, noise_px / kFocal)));
    data.outlier.push_back(outlier);
  }
  return data;
}

Scene make_scene(const Truth& truth, double noise_px, int clutter,
                 std::mt19937& rng) {
  Scene scene;
  SceneCamera camera;
  camera.id = "camera-0";
  camera.original = centred_camera(kWidth, kHeight, kFocal, "calibrated");
  camera.original.cx = kCx;
  camera.original.cy = kCy;
  camera.params = {kFocal, kFocal, kCx, kCy, 0, 0};
  scene.cameras.push_back(camera);

  std::uniform_int_distribution<int> byte(0, 255);
  std::normal_distribution<float> component(0, 1);
  for (size_t i = 0; i < truth.poses.size(); ++i) {
    SceneImage image;
    image.id = "image-" + std::to_string(i);
    image.width = kWidth;
    image.height = kHeight;
    image.registered = true;
    image.status = CaptureStatus::kRegistered;
    image.q = truth.poses[i].q;
    image.t = truth.poses[i].t;
    scene.images.push_back(image);
  }
  for (size_t p = 0; p < truth.points.size(); ++p) {
    ScenePoint point;
    point.xyz = truth.points[p];
    point.rgb = {static_cast<uint8_t>(byte(rng)),
                 static_cast<uint8_t>(byte(rng)),
                 static_cast<uint8_t>(byte(rng))};
    for (size_t i = 0; i < truth.poses.size(); ++i) {
      const auto x = project_normalized(truth.poses[i], truth.points[p]);
      if (!x || !in_image(*x)) continue;
      SceneImage& image = scene.images[i];
      const Eigen::Vector2d pixel(kFocal * x->x() + kCx, kFocal * x->y() + kCy);
      point.track.push_back(
          {static_cast<int>(i), static_cast<int>(image.keypoints.size())});
      image.keypoints.push_back(pixel + gaussian2(rng, noise_px));
      image.colors.push_back(point.rgb);
      image.point_of.push_back(static_cast<int64_t>(p));
    }
    if (point.track.size() >= 2) {
      scene.points[static_cast<int64_t>(p)] = point;
    } else {  // a point seen once constrains nothing: drop its observation
      for (const Observation& obs : point.track) {
        scene.images[obs.image].point_of[obs.keypoint] = -1;
      }
    }
  }
  scene.next_point_id = static_cast<int64_t>(truth.points.size());
  for (SceneImage& image : scene.images) {
    for (int c = 0; c < clutter; ++c) {
      const Eigen::Vector2d x = random_image_point(rng);
      image.keypoints.emplace_back(kFocal * x.x() + kCx, kFocal * x.y() + kCy);
      image.colors.push_back({0, 0, 0});
      image.point_of.push_back(-1);
    }
    image.descriptors =
        cv::Mat(static_cast<int>(image.keypoints.size()), 128, CV_32F);
    for (int r = 0; r < image.descriptors.rows; ++r) {
      float* row = image.descriptors.ptr<float>(r);
      float norm = 0;
      for (int k = 0; k < 128; ++k) {
        row[k] = std::abs(component(rng));  // RootSIFT rows are non-negative
        norm += row[k] * row[k];
      }
      for (int k = 0; k < 128; ++k) row[k] /= std::sqrt(norm);
    }
  }
  scene.initialized = true;
  scene.reference_image = 0;
  scene.scale_image = truth.poses.size() > 1 ? 1 : -1;
  scene.registered_at_last_global_ba = static_cast<int>(truth.poses.size());
  return scene;
}

double rotation_error_deg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return Eigen::AngleAxisd(a * b.transpose()).angle() * 180 / M_PI;
}

double direction_error_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const double c = a.normalized().dot(b.normalized());
  return std::acos(std::clamp(c, -1.0, 1.0)) * 180 / M_PI;
}

double reprojection_rms_px(const Scene& scene) {
  double sum = 0;
  int count = 0;
  for (const auto& [id, point] : scene.points) {
    for (const Observation& obs : point.track) {
      const SceneImage& image = scene.images[obs.image];
      Eigen::Vector2d pixel;
      if (!project(scene.cameras[image.camera], image, point.xyz, &pixel)) {
        return HUGE_VAL;  // a point behind its camera: the model is broken
      }
      sum += (pixel - image.keypoints[obs.keypoint]).squaredNorm();
      count += 2;
    }
  }
  return count ? std::sqrt(sum / count) : 0;
}

}  // namespace arscout::engine::synthetic
