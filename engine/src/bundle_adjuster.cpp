#include "bundle_adjuster.h"

#include <cmath>
#include <set>

#include <ceres/ceres.h>
#include <ceres/rotation.h>

namespace arscout::engine {
namespace {

// Residual in working pixels. Intrinsics block: fx, fy, cx, cy, k1, k2; the
// aspect fy/fx stays as given, so fy follows fx.
struct ReprojectionCost {
  ReprojectionCost(const Eigen::Vector2d& observed, double aspect)
      : x(observed.x()), y(observed.y()), aspect(aspect) {}

  template <typename T>
  bool operator()(const T* q, const T* t, const T* point, const T* k,
                  T* residual) const {
    // Eigen quaternion storage is x, y, z, w; Ceres wants w first.
    const T q_wxyz[4] = {q[3], q[0], q[1], q[2]};
    T p[3];
    ceres::QuaternionRotatePoint(q_wxyz, point, p);
    p[0] += t[0];
    p[1] += t[1];
    p[2] += t[2];
    const T xn = p[0] / p[2];
    const T yn = p[1] / p[2];
    const T r2 = xn * xn + yn * yn;
    const T d = T(1) + k[4] * r2 + k[5] * r2 * r2;
    residual[0] = k[0] * d * xn + k[2] - T(x);
    residual[1] = k[0] * T(aspect) * d * yn + k[3] - T(y);
    return true;
  }

  static ceres::CostFunction* create(const Eigen::Vector2d& observed, double aspect) {
    return new ceres::AutoDiffCostFunction<ReprojectionCost, 2, 4, 3, 3, 6>(
        new ReprojectionCost(observed, aspect));
  }

  double x, y, aspect;
};

// The camera centre -R^T t against its ENU fix, in units of the fix's
// standard deviation per axis (zero weight where the axis is unknown).
struct GpsPriorCost {
  GpsPriorCost(const Eigen::Vector3d& enu, const Eigen::Vector3d& inverse_sigma)
      : enu(enu), inverse_sigma(inverse_sigma) {}

  template <typename T>
  bool operator()(const T* q, const T* t, T* residual) const {
    const T q_inverse[4] = {q[3], -q[0], -q[1], -q[2]};
    T centre[3];
    ceres::QuaternionRotatePoint(q_inverse, t, centre);
    for (int i = 0; i < 3; ++i) {
      residual[i] = (-centre[i] - T(enu[i])) * T(inverse_sigma[i]);
    }
    return true;
  }

  static ceres::CostFunction* create(const Eigen::Vector3d& enu,
                                     const Eigen::Vector3d& inverse_sigma) {
    return new ceres::AutoDiffCostFunction<GpsPriorCost, 3, 4, 3>(
        new GpsPriorCost(enu, inverse_sigma));
  }

  Eigen::Vector3d enu, inverse_sigma;
};

Eigen::Vector3d inverse_sigma(const GeoFix& fix) {
  const double h = 1.0 / std::max(fix.h_acc, 0.01);
  const double v = fix.alt ? 1.0 / std::max(fix.v_acc, 0.01) : 0.0;
  return {h, h, v};
}

double aspect_of(const SceneCamera& camera) {
  return camera.params[1] / camera.params[0];
}

class ProblemBuilder {
 public:
  ProblemBuilder(Scene& scene, const BundleOptions& options)
      : scene_(scene), options_(options), loss_(new ceres::CauchyLoss(options.loss_scale_px)) {}

  void select(const std::vector<int>& free_images, bool global) {
    global_ = global;
    for (size_t i = 0; i < scene_.images.size(); ++i) {
      if (scene_.images[i].registered && global) free_.insert(static_cast<int>(i));
    }
    if (!global) {
      for (int i : free_images) free_.insert(i);
    }
    for (const auto& [id, point] : scene_.points) {
      for (const Observation& obs : point.track) {
        if (free_.count(obs.image)) {
          points_.insert(id);
          break;
        }
      }
    }
  }

  void build() {
    for (int64_t id : points_) {
      ScenePoint& point = scene_.points.at(id);
      for (const Observation& obs : point.track) add_observation(point, obs);
    }
    if (options_.gps_priors) add_gps_priors();
    hold_gauge();
    hold_cameras();
  }

  ceres::Problem& problem() { return problem_; }
  int image_count() const { return static_cast<int>(images_.size()); }
  int point_count() const { return static_cast<int>(points_.size()); }

  void normalize_quaternions() {
    for (int i : images_) scene_.images[i].q.normalize();
    for (int c : cameras_) {
      SceneCamera& camera = scene_.cameras[c];
      camera.params[1] = camera.params[0] * aspects_.at(c);
    }
  }

 private:
  void add_observation(ScenePoint& point, const Observation& obs) {
    SceneImage& image = scene_.images[obs.image];
    if (!image.registered) return;
    SceneCamera& camera = scene_.cameras[image.camera];
    aspects_.emplace(image.camera, aspect_of(camera));
    problem_.AddResidualBlock(
        ReprojectionCost::create(image.keypoints[obs.keypoint], aspect_of(camera)),
        loss_, image.q.coeffs().data(), image.t.data(), point.xyz.data(),
        camera.params.data());
    add_image(obs.image);
    cameras_.insert(image.camera);
  }

  void add_image(int index) {
    if (!images_.insert(index).second) return;
    SceneImage& image = scene_.images[index];
    problem_.SetManifold(image.q.coeffs().data(), new ceres::EigenQuaternionManifold);
    if (!free_.count(index)) {
      problem_.SetParameterBlockConstant(image.q.coeffs().data());
      problem_.SetParameterBlockConstant(image.t.data());
    }
  }

  void add_gps_priors() {
    for (int index : images_) {
      SceneImage& image = scene_.images[index];
      if (!image.gps || !free_.count(index)) continue;
      problem_.AddResidualBlock(
          GpsPriorCost::create(image.gps_enu, inverse_sigma(*image.gps)), nullptr,
          image.q.coeffs().data(), image.t.data());
    }
  }

  // Without priors the model floats: pin one pose, and in a global
  // adjustment one coordinate of a second camera's position for the scale.
  void hold_gauge() {
    if (options_.gps_priors) return;
    const int ref = scene_.reference_image;
    if (ref >= 0 && images_.count(ref)) {
      problem_.SetParameterBlockConstant(scene_.images[ref].q.coeffs().data());
      problem_.SetParameterBlockConstant(scene_.images[ref].t.data());
    }
    const int second = scene_.scale_image;
    if (!global_ || second < 0 || !images_.count(second) || !free_.count(second)) return;
    SceneImage& image = scene_.images[second];
    int largest = 0;
    image.t.cwiseAbs().maxCoeff(&largest);
    problem_.SetManifold(image.t.data(), new ceres::SubsetManifold(3, {largest}));
  }

  // Intrinsics move only in a global adjustment, and only for cameras that
  // asked for it; cx, cy always stay (they are poorly observed).
  void hold_cameras() {
    for (int c : cameras_) {
      double* params = scene_.cameras[c].params.data();
      if (!global_ || !scene_.cameras[c].refine) {
        problem_.SetParameterBlockConstant(params);
      } else {
        problem_.SetManifold(params, new ceres::SubsetManifold(6, {1, 2, 3}));
      }
    }
  }

  Scene& scene_;
  const BundleOptions& options_;
  ceres::LossFunction* loss_;  // owned by the problem
  ceres::Problem problem_;
  bool global_ = false;
  std::set<int> free_;
  std::set<int> images_;
  std::set<int> cameras_;
  std::map<int, double> aspects_;
  std::set<int64_t> points_;
};

}  // namespace

BundleReport adjust_bundle(Scene& scene, const std::vector<int>& free_images,
                           bool global, const BundleOptions& options) {
  ProblemBuilder builder(scene, options);
  builder.select(free_images, global);
  builder.build();
  BundleReport report;
  report.images = builder.image_count();
  report.points = builder.point_count();
  if (report.points == 0) return report;
  ceres::Solver::Options solver;
  solver.linear_solver_type = report.images <= 60 ? ceres::DENSE_SCHUR : ceres::SPARSE_SCHUR;
  if (!ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::SUITE_SPARSE) &&
      solver.linear_solver_type == ceres::SPARSE_SCHUR) {
    solver.linear_solver_type = ceres::ITERATIVE_SCHUR;
  }
  solver.max_num_iterations = options.max_iterations;
  solver.num_threads = std::max(1, options.threads);
  solver.function_tolerance = 1e-7;
  solver.parameter_tolerance = 1e-9;
  solver.logging_type = ceres::SILENT;
  solver.minimizer_progress_to_stdout = false;
  ceres::Solver::Summary summary;
  ceres::Solve(solver, &builder.problem(), &summary);
  builder.normalize_quaternions();
  report.iterations = static_cast<int>(summary.iterations.size());
  report.initial_rms_px = std::sqrt(2 * summary.initial_cost / std::max(1, summary.num_residuals));
  report.final_rms_px = std::sqrt(2 * summary.final_cost / std::max(1, summary.num_residuals));
  return report;
}

}  // namespace arscout::engine
