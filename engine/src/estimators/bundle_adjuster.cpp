#include "estimators/bundle_adjuster.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <set>

#include <ceres/ceres.h>
#include <ceres/rotation.h>

namespace arscout::engine {
namespace {

// d(R(q / |q|) X) / dq for q in Eigen's storage order (x, y, z, w). With
// q = (w, v), M(q) X = (w^2 - v.v) X + 2 (v.X) v + 2 w (v x X) equals
// |q|^2 R(q / |q|) X for every q, which gives the derivative of the
// normalized rotation (as ceres::QuaternionRotatePoint applies it).
Eigen::Matrix<double, 3, 4> rotation_derivative(const double* q,
                                                const Eigen::Vector3d& x) {
  const Eigen::Vector3d v(q[0], q[1], q[2]);
  const double w = q[3];
  const double norm2 = v.squaredNorm() + w * w;
  const Eigen::Vector3d m =
      (w * w - v.squaredNorm()) * x + 2 * v.dot(x) * v + 2 * w * v.cross(x);
  Eigen::Matrix3d x_cross;
  x_cross << 0, -x.z(), x.y(), x.z(), 0, -x.x(), -x.y(), x.x(), 0;
  Eigen::Matrix<double, 3, 4> dm;
  dm.leftCols<3>() = -2 * x * v.transpose() +
                     2 * v.dot(x) * Eigen::Matrix3d::Identity() +
                     2 * v * x.transpose() - 2 * w * x_cross;
  dm.col(3) = 2 * w * x + 2 * v.cross(x);
  const Eigen::Vector4d q_vector(q[0], q[1], q[2], q[3]);
  return dm / norm2 - (2 / (norm2 * norm2)) * m * q_vector.transpose();
}

using RowMajor23 = Eigen::Matrix<double, 2, 3, Eigen::RowMajor>;

// The derivatives of the residual (below) from d(residual)/d(camera-frame
// point), into Ceres' row-major blocks; a null block is not wanted (held).
void reprojection_jacobians(const double* q, const double* point,
                            const RowMajor23& dr_dp, double** jacobians) {
  const Eigen::Map<const Eigen::Vector3d> x(point);
  using RowMajor24 = Eigen::Matrix<double, 2, 4, Eigen::RowMajor>;
  if (jacobians[0]) {
    Eigen::Map<RowMajor24> dq(jacobians[0]);
    dq = dr_dp * rotation_derivative(q, x);
  }
  if (jacobians[1]) {
    Eigen::Map<RowMajor23> dt(jacobians[1]);
    dt = dr_dp;
  }
  if (jacobians[2]) {
    const Eigen::Quaterniond rotation(q[3], q[0], q[1], q[2]);
    Eigen::Map<RowMajor23> dx(jacobians[2]);
    dx = dr_dp * rotation.normalized().toRotationMatrix();
  }
}

}  // namespace

// The residual in working pixels: the point through the pose (q in Eigen's
// storage order x, y, z, w; normalized as applied) and the intrinsics k =
// fx, fy, cx, cy, k1, k2, where fy follows fx by `aspect`, minus the
// keypoint. Derivatives by hand: automatic differentiation carried all 16
// unknowns through every residual even when the pose or the camera is held,
// and was a third of an adjustment's time.
bool evaluate_reprojection(const double* q, const double* t,
                           const double* point, const double* k,
                           const Eigen::Vector2d& observed, double aspect,
                           double* residual, double** jacobians) {
  const double q_wxyz[4] = {q[3], q[0], q[1], q[2]};
  double p[3];
  ceres::QuaternionRotatePoint(q_wxyz, point, p);
  for (int i = 0; i < 3; ++i) p[i] += t[i];
  const double xn = p[0] / p[2], yn = p[1] / p[2];
  const double r2 = xn * xn + yn * yn;
  const double d = 1 + k[4] * r2 + k[5] * r2 * r2;
  const double fx = k[0], fy = k[0] * aspect;
  residual[0] = fx * d * xn + k[2] - observed.x();
  residual[1] = fy * d * yn + k[3] - observed.y();
  if (!jacobians) return true;
  const double g = 2 * (k[4] + 2 * k[5] * r2);  // d(d)/d(r2), doubled
  Eigen::Matrix2d dr_dn;
  dr_dn << fx * (d + g * xn * xn), fx * g * xn * yn, fy * g * xn * yn,
      fy * (d + g * yn * yn);
  Eigen::Matrix<double, 2, 3> dn_dp;
  dn_dp << 1 / p[2], 0, -xn / p[2], 0, 1 / p[2], -yn / p[2];
  reprojection_jacobians(q, point, dr_dn * dn_dp, jacobians);
  if (jacobians[3]) {
    Eigen::Map<Eigen::Matrix<double, 2, 6, Eigen::RowMajor>> dk(jacobians[3]);
    dk << d * xn, 0, 1, 0, fx * xn * r2, fx * xn * r2 * r2,  //
        aspect * d * yn, 0, 0, 1, fy * yn * r2, fy * yn * r2 * r2;
  }
  return true;
}

namespace {

// One observation's residual for the solver (evaluate_reprojection).
class ReprojectionCost final : public ceres::SizedCostFunction<2, 4, 3, 3, 6> {
 public:
  ReprojectionCost(const Eigen::Vector2d& observed, double aspect)
      : observed_(observed), aspect_(aspect) {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    return evaluate_reprojection(parameters[0], parameters[1], parameters[2],
                                 parameters[3], observed_, aspect_, residuals,
                                 jacobians);
  }

 private:
  Eigen::Vector2d observed_;
  double aspect_;
};

// The GPS priors are plain least squares, the upright prior has this
// Cauchy scale (in its own deviations), in the adjustment and in the fit
// that places a model before it (fit_model_to_priors) alike. Where the fit
// was robust on the fixes and the adjustment not, a fix far off made them
// disagree on where the model sits, and the adjustment spent its
// iterations dragging the whole model back (docs/engine.md, "One weighing
// of the priors"). Robust fixes in both let a small component placed far
// from its fixes stay there (the fit then ran off to scales of e^13775).
constexpr double kUprightLossSigmas = 3.0;
// How far fit_model_to_priors may take the scale from its start: a factor
// of 100 either way (the start is a closed-form fit to the same fixes).
constexpr double kLogScaleRange = 4.6;

// A camera centre against its ENU fix, in units of the fix's standard
// deviation per axis (zero weight where the axis is unknown): the one
// residual of GpsPriorCost and of the fit's SimilarityFixCost.
template <typename T>
void fix_residual(const T* centre, const Eigen::Vector3d& enu,
                  const Eigen::Vector3d& inverse_sigma, T* residual) {
  for (int i = 0; i < 3; ++i)
    residual[i] = (centre[i] - T(enu[i])) * T(inverse_sigma[i]);
}

// The camera centre -R^T t against its ENU fix (fix_residual).
struct GpsPriorCost {
  GpsPriorCost(const Eigen::Vector3d& enu, const Eigen::Vector3d& inverse_sigma)
      : enu(enu), inverse_sigma(inverse_sigma) {}

  template <typename T>
  bool operator()(const T* q, const T* t, T* residual) const {
    const T q_inverse[4] = {q[3], -q[0], -q[1], -q[2]};
    T rotated[3];
    ceres::QuaternionRotatePoint(q_inverse, t, rotated);
    const T centre[3] = {-rotated[0], -rotated[1], -rotated[2]};
    fix_residual(centre, enu, inverse_sigma, residual);
    return true;
  }

  static ceres::CostFunction* create(const Eigen::Vector3d& enu,
                                     const Eigen::Vector3d& inverse_sigma) {
    return new ceres::AutoDiffCostFunction<GpsPriorCost, 3, 4, 3>(
        new GpsPriorCost(enu, inverse_sigma));
  }

  Eigen::Vector3d enu, inverse_sigma;
};

// The camera's x axis in the world is the first row of R (world-to-camera);
// its up component is the sine of the roll, zero for a level camera.
struct UprightCost {
  explicit UprightCost(double inverse_sigma) : inverse_sigma(inverse_sigma) {}

  template <typename T>
  bool operator()(const T* q, T* residual) const {
    const T q_inverse[4] = {q[3], -q[0], -q[1], -q[2]};
    const T x_axis[3] = {T(1), T(0), T(0)};
    T world[3];
    ceres::QuaternionRotatePoint(q_inverse, x_axis, world);
    residual[0] = world[2] * T(inverse_sigma);
    return true;
  }

  static ceres::CostFunction* create(double inverse_sigma) {
    return new ceres::AutoDiffCostFunction<UprightCost, 1, 4>(
        new UprightCost(inverse_sigma));
  }

  double inverse_sigma;
};

Eigen::Vector3d inverse_sigma(const GeoFix& fix) {
  const double h = 1.0 / std::max(fix.h_acc, 0.01);
  const double v = fix.alt ? 1.0 / std::max(fix.v_acc, 0.01) : 0.0;
  return {h, h, v};
}

double aspect_of(const SceneCamera& camera) {
  return camera.params[1] / camera.params[0];
}

ceres::Problem::Options problem_options() {
  ceres::Problem::Options options;
  options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  return options;
}

// Cauchy in pixels, scaled by 1 / sigma^2: the same robustness to outliers
// whatever the weight of the inliers.
ceres::LossFunction* reprojection_loss(double loss_scale_px, double sigma) {
  return new ceres::ScaledLoss(new ceres::CauchyLoss(loss_scale_px),
                               1.0 / (sigma * sigma), ceres::TAKE_OWNERSHIP);
}

// The keypoint deviation from residual norms: for a 2D Gaussian the median
// norm is sigma sqrt(2 ln 2); the residuals of a fitted model are smaller
// than the noise by the share of degrees of freedom the points take up.
double estimate_pixel_sigma(std::vector<double> norms, size_t points) {
  constexpr double kMin = 0.1, kMax = 1.0;
  if (norms.size() < 20) return kMax;
  std::nth_element(norms.begin(), norms.begin() + norms.size() / 2,
                   norms.end());
  const double median = norms[norms.size() / 2];
  const double residuals = 2.0 * static_cast<double>(norms.size());
  const double freedom =
      std::max(0.25, 1.0 - 3.0 * static_cast<double>(points) / residuals);
  const double sigma = median / std::sqrt(2 * std::log(2.0) * freedom);
  return std::clamp(sigma, kMin, kMax);
}

class ProblemBuilder {
 public:
  ProblemBuilder(Scene& scene, const BundleOptions& options)
      : scene_(scene),
        options_(options),
        loss_(std::make_unique<ceres::LossFunctionWrapper>(
            reprojection_loss(options.loss_scale_px, 1.0),
            ceres::TAKE_OWNERSHIP)),
        upright_loss_(std::make_unique<ceres::CauchyLoss>(kUprightLossSigmas)),
        problem_(problem_options()) {}

  void select(const std::vector<int>& free_images, bool global) {
    global_ = global;
    const bool subset = !options_.global_images.empty();
    for (size_t i = 0; i < scene_.images.size(); ++i) {
      if (scene_.images[i].registered && global &&
          (!subset || options_.global_images.count(static_cast<int>(i))))
        free_.insert(static_cast<int>(i));
    }
    if (!global) {
      for (int i : free_images) free_.insert(i);
    }
    if (global) {
      for (const auto& [id, point] : scene_.points) points_.insert(id);
      return;
    }
    // The free images' points, found through their keypoints: O(window),
    // not O(model).
    for (int i : free_) {
      const std::vector<int64_t>& point_of = scene_.images[i].point_of;
      for (size_t k = 0; k < point_of.size() && strong(static_cast<int>(k));
           ++k) {
        if (point_of[k] >= 0) points_.insert(point_of[k]);
      }
    }
    choose_fixed_images();
  }

  // False when BundleOptions::stop asked to end while the problem was
  // being built (asked every kPointsPerStopCheck points): on a large
  // model building it takes longer than an iteration, and a capture
  // arriving meanwhile would wait for all of it.
  bool build() {
    constexpr size_t kPointsPerStopCheck = 4096;
    size_t added = 0;
    for (int64_t id : points_) {
      if (options_.stop && ++added % kPointsPerStopCheck == 0 &&
          options_.stop())
        return false;
      ScenePoint& point = scene_.points.at(id);
      const std::vector<Observation> kept = kept_observations(point);
      for (const Observation& obs : kept) add_observation(point, obs);
      if (options_.points_fixed && !kept.empty())
        problem_.SetParameterBlockConstant(point.xyz.data());
    }
    weigh_reprojections();
    if (options_.gps_priors) add_gps_priors();
    if (options_.gps_priors && options_.upright_sigma_deg > 0)
      add_upright_priors();
    hold_gauge();
    hold_cameras();
    return true;
  }

  ceres::Problem& problem() { return problem_; }
  int image_count() const { return static_cast<int>(images_.size()); }
  int point_count() const { return static_cast<int>(points_.size()); }
  double pixel_sigma() const { return pixel_sigma_; }
  double loss_scale_px() const { return loss_scale_px_; }

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
    Eigen::Vector2d projected;
    if (options_.pixel_sigma <= 0 &&
        project(camera, image, point.xyz, &projected))
      residual_norms_.push_back(
          (projected - image.keypoints[obs.keypoint]).norm());
    aspects_.emplace(image.camera, aspect_of(camera));
    problem_.AddResidualBlock(
        new ReprojectionCost(image.keypoints[obs.keypoint], aspect_of(camera)),
        loss_.get(), image.q.coeffs().data(), image.t.data(), point.xyz.data(),
        camera.params.data());
    add_image(obs.image);
    cameras_.insert(image.camera);
  }

  void add_image(int index) {
    if (!images_.insert(index).second) return;
    SceneImage& image = scene_.images[index];
    problem_.SetManifold(image.q.coeffs().data(),
                         new ceres::EigenQuaternionManifold);
    if (!free_.count(index)) {
      problem_.SetParameterBlockConstant(image.q.coeffs().data());
      problem_.SetParameterBlockConstant(image.t.data());
    }
  }

  void weigh_reprojections() {
    pixel_sigma_ =
        options_.pixel_sigma > 0
            ? options_.pixel_sigma
            : estimate_pixel_sigma(std::move(residual_norms_), points_.size());
    loss_scale_px_ = options_.loss_scale_sigmas > 0
                         ? options_.loss_scale_sigmas * pixel_sigma_
                         : options_.loss_scale_px;
    loss_->Reset(reprojection_loss(loss_scale_px_, pixel_sigma_),
                 ceres::TAKE_OWNERSHIP);
  }

  void add_gps_priors() {
    for (int index : images_) {
      SceneImage& image = scene_.images[index];
      if (!image.gps || !free_.count(index)) continue;
      problem_.AddResidualBlock(
          GpsPriorCost::create(image.gps_enu, inverse_sigma(*image.gps)),
          nullptr, image.q.coeffs().data(), image.t.data());
    }
  }

  void add_upright_priors() {
    const double inverse_sigma =
        1.0 / std::sin(options_.upright_sigma_deg * M_PI / 180);
    for (int index : images_) {
      if (!free_.count(index)) continue;
      problem_.AddResidualBlock(UprightCost::create(inverse_sigma),
                                upright_loss_.get(),
                                scene_.images[index].q.coeffs().data());
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
    if (!global_ || second < 0 || !images_.count(second) ||
        !free_.count(second))
      return;
    SceneImage& image = scene_.images[second];
    int largest = 0;
    image.t.cwiseAbs().maxCoeff(&largest);
    problem_.SetManifold(image.t.data(),
                         new ceres::SubsetManifold(3, {largest}));
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

  // The images outside the window that share the most points with it;
  // only these are held fixed (all of them when there is no limit).
  void choose_fixed_images() {
    std::map<int, int> shared;
    for (int64_t id : points_) {
      for (const Observation& obs : scene_.points.at(id).track) {
        if (!free_.count(obs.image) && strong(obs.keypoint))
          ++shared[obs.image];
      }
    }
    std::vector<std::pair<int, int>> ranked;
    for (const auto& [image, count] : shared) ranked.push_back({-count, image});
    std::sort(ranked.begin(), ranked.end());
    const size_t limit = options_.max_fixed_images > 0
                             ? static_cast<size_t>(options_.max_fixed_images)
                             : ranked.size();
    for (size_t i = 0; i < ranked.size() && i < limit; ++i)
      fixed_.insert(ranked[i].second);
    limit_fixed_ = options_.max_fixed_images > 0;
  }

  // A point's observations in the problem: all in a global adjustment; in a
  // local one the free images' and the chosen fixed ones', up to the cap.
  // A point left with one observation stays out (nothing constrains it).
  std::vector<Observation> kept_observations(const ScenePoint& point) const {
    if (global_) return global_observations(point);
    std::vector<Observation> kept;
    for (const Observation& obs : point.track) {
      if (free_.count(obs.image) && strong(obs.keypoint)) kept.push_back(obs);
    }
    if (options_.points_fixed) return kept;  // the others add nothing
    const size_t cap =
        options_.max_track_observations > 0
            ? static_cast<size_t>(options_.max_track_observations)
            : point.track.size();
    for (const Observation& obs : point.track) {
      if (kept.size() >= cap) break;
      if (free_.count(obs.image) || !strong(obs.keypoint)) continue;
      if (limit_fixed_ && !fixed_.count(obs.image)) continue;
      kept.push_back(obs);
    }
    if (kept.size() < 2) kept.clear();
    return kept;
  }

  bool strong(int keypoint) const {
    return options_.strong_keypoints <= 0 ||
           keypoint < options_.strong_keypoints;
  }

  std::vector<Observation> global_observations(const ScenePoint& point) const {
    if (options_.global_images.empty() && options_.max_track_observations == 0)
      return point.track;
    std::vector<Observation> in;
    for (const Observation& obs : point.track) {
      if (free_.count(obs.image)) in.push_back(obs);
    }
    const size_t cap = static_cast<size_t>(options_.max_track_observations);
    if (cap >= 2 && in.size() > cap) {
      std::vector<Observation> spread;
      for (size_t k = 0; k < cap; ++k)
        spread.push_back(in[k * (in.size() - 1) / (cap - 1)]);
      in = std::move(spread);
    }
    if (in.size() < 2) in.clear();
    return in;
  }

  Scene& scene_;
  const BundleOptions& options_;
  // Declared before the problem, which uses but does not own them.
  std::unique_ptr<ceres::LossFunctionWrapper> loss_;
  std::unique_ptr<ceres::LossFunction> upright_loss_;  // in units of sigma
  std::vector<double> residual_norms_;                 // before solving, pixels
  double pixel_sigma_ = 1;
  double loss_scale_px_ = 1;
  ceres::Problem problem_;
  bool global_ = false;
  std::set<int> free_;
  std::set<int> fixed_;  // local: the fixed images allowed in
  bool limit_fixed_ = false;
  std::set<int> images_;
  std::set<int> cameras_;
  std::map<int, double> aspects_;
  std::set<int64_t> points_;
};

// A camera's centre after the similarity (log scale, R as a quaternion, t)
// against its fix (fix_residual): GpsPriorCost with the model moved as a
// whole.
struct SimilarityFixCost {
  SimilarityFixCost(const Eigen::Vector3d& centre, const Eigen::Vector3d& enu,
                    const Eigen::Vector3d& inverse_sigma)
      : centre(centre), enu(enu), inverse_sigma(inverse_sigma) {}

  template <typename T>
  bool operator()(const T* log_scale, const T* q, const T* t,
                  T* residual) const {
    const T q_wxyz[4] = {q[3], q[0], q[1], q[2]};
    const T c[3] = {T(centre[0]), T(centre[1]), T(centre[2])};
    T rotated[3];
    ceres::QuaternionRotatePoint(q_wxyz, c, rotated);
    const T scale = exp(log_scale[0]);
    const T moved[3] = {scale * rotated[0] + t[0], scale * rotated[1] + t[1],
                        scale * rotated[2] + t[2]};
    fix_residual(moved, enu, inverse_sigma, residual);
    return true;
  }

  Eigen::Vector3d centre, enu, inverse_sigma;
};

// A camera's x axis after the similarity's rotation against the upright
// prior: UprightCost with the model turned as a whole.
struct SimilarityUprightCost {
  SimilarityUprightCost(const Eigen::Vector3d& x_axis, double inverse_sigma)
      : x_axis(x_axis), inverse_sigma(inverse_sigma) {}

  template <typename T>
  bool operator()(const T* q, T* residual) const {
    const T q_wxyz[4] = {q[3], q[0], q[1], q[2]};
    const T x[3] = {T(x_axis[0]), T(x_axis[1]), T(x_axis[2])};
    T axis[3];
    ceres::QuaternionRotatePoint(q_wxyz, x, axis);
    residual[0] = axis[2] * T(inverse_sigma);
    return true;
  }

  Eigen::Vector3d x_axis;
  double inverse_sigma;
};

// First-order (Sampson) distance of a correspondence to E = [t]x R.
struct SampsonCost {
  SampsonCost(const Eigen::Vector2d& x1, const Eigen::Vector2d& x2)
      : x1(x1), x2(x2) {}

  template <typename T>
  bool operator()(const T* q, const T* t, T* residual) const {
    const T q_wxyz[4] = {q[3], q[0], q[1], q[2]};
    const T p1[3] = {T(x1.x()), T(x1.y()), T(1)};
    T Rp1[3];
    ceres::QuaternionRotatePoint(q_wxyz, p1, Rp1);
    T Ex1[3];  // t x (R p1)
    ceres::CrossProduct(t, Rp1, Ex1);
    // E^T x2 = -R^T (t x x2); the sign does not matter once squared.
    const T p2[3] = {T(x2.x()), T(x2.y()), T(1)};
    T t_cross_p2[3];
    ceres::CrossProduct(t, p2, t_cross_p2);
    const T q_inverse[4] = {q[3], -q[0], -q[1], -q[2]};
    T Etx2[3];
    ceres::QuaternionRotatePoint(q_inverse, t_cross_p2, Etx2);
    residual[0] = sampson_distance(Ex1, Etx2, p2);
    return true;
  }

  Eigen::Vector2d x1, x2;
};

// Ends a solve when the caller asks; the solver then keeps the last
// accepted iterate.
class StopCallback : public ceres::IterationCallback {
 public:
  explicit StopCallback(const std::function<bool()>& stop) : stop_(stop) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary&) final {
    if (!stop_ || !stop_()) return ceres::SOLVER_CONTINUE;
    stopped_ = true;
    return ceres::SOLVER_TERMINATE_SUCCESSFULLY;
  }
  bool stopped() const { return stopped_; }

 private:
  const std::function<bool()>& stop_;
  bool stopped_ = false;
};

}  // namespace

void refine_relative_pose(const std::vector<Eigen::Vector2d>& x1,
                          const std::vector<Eigen::Vector2d>& x2,
                          const std::vector<int>& inliers, Eigen::Matrix3d* R,
                          Eigen::Vector3d* t) {
  if (inliers.size() < 6) return;
  Eigen::Quaterniond q(*R);
  Eigen::Vector3d direction = t->normalized();
  ceres::Problem problem;
  for (int i : inliers) {
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<SampsonCost, 1, 4, 3>(
            new SampsonCost(x1[i], x2[i])),
        nullptr, q.coeffs().data(), direction.data());
  }
  problem.SetManifold(q.coeffs().data(), new ceres::EigenQuaternionManifold);
  problem.SetManifold(direction.data(), new ceres::SphereManifold<3>);
  ceres::Solver::Options solver;
  solver.linear_solver_type = ceres::DENSE_QR;
  solver.max_num_iterations = 20;
  solver.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(solver, &problem, &summary);
  if (!summary.IsSolutionUsable()) return;
  *R = q.normalized().toRotationMatrix();
  *t = direction.normalized();
}

std::optional<Similarity> fit_model_to_priors(const Scene& scene,
                                              const BundleOptions& options,
                                              int component,
                                              const Similarity& start) {
  const double upright =
      options.upright_sigma_deg > 0
          ? 1.0 / std::sin(options.upright_sigma_deg * M_PI / 180)
          : 0;
  if (!(start.scale > 0)) return std::nullopt;
  double log_scale = std::log(start.scale);
  Eigen::Quaterniond q(start.R);
  Eigen::Vector3d t = start.t;
  ceres::Problem problem;
  int fixes = 0;
  for (const SceneImage& image : scene.images) {
    if (!image.registered || !image.gps || image.component != component)
      continue;
    ++fixes;
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<SimilarityFixCost, 3, 1, 4, 3>(
            new SimilarityFixCost(image.centre(), image.gps_enu,
                                  inverse_sigma(*image.gps))),
        nullptr, &log_scale, q.coeffs().data(), t.data());
    if (upright <= 0) continue;
    const Eigen::Vector3d x_axis =
        image.q.toRotationMatrix().row(0).transpose();
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<SimilarityUprightCost, 1, 4>(
            new SimilarityUprightCost(x_axis, upright)),
        new ceres::CauchyLoss(kUprightLossSigmas), q.coeffs().data());
  }
  if (fixes < 3) return std::nullopt;
  problem.SetManifold(q.coeffs().data(), new ceres::EigenQuaternionManifold);
  // A component whose centres nearly coincide (photos turned on the spot)
  // leaves the scale almost free: a trial step once reached a log scale of
  // 10500, whose cost is infinite (Ceres rejects it, but logs the whole
  // block to stderr). The fit only refines the start's scale.
  problem.SetParameterLowerBound(&log_scale, 0, log_scale - kLogScaleRange);
  problem.SetParameterUpperBound(&log_scale, 0, log_scale + kLogScaleRange);
  ceres::Solver::Options solver;
  solver.linear_solver_type = ceres::DENSE_QR;
  solver.max_num_iterations = 100;
  solver.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(solver, &problem, &summary);
  if (!summary.IsSolutionUsable()) return std::nullopt;
  Similarity sim;
  sim.scale = std::exp(log_scale);
  sim.R = q.normalized().toRotationMatrix();
  sim.t = t;
  return sim;
}

BundleReport adjust_bundle(Scene& scene, const std::vector<int>& free_images,
                           bool global, const BundleOptions& options) {
  ProblemBuilder builder(scene, options);
  builder.select(free_images, global);
  const bool built = builder.build();
  BundleReport report;
  report.images = builder.image_count();
  report.points = builder.point_count();
  report.stopped = !built;
  if (!built || report.points == 0) return report;
  ceres::Solver::Options solver;
  solver.linear_solver_type =
      report.images <= 60 ? ceres::DENSE_SCHUR : ceres::SPARSE_SCHUR;
  if (!ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::SUITE_SPARSE) &&
      solver.linear_solver_type == ceres::SPARSE_SCHUR) {
    solver.linear_solver_type = ceres::ITERATIVE_SCHUR;
  }
  solver.max_num_iterations = options.max_iterations;
  solver.num_threads = std::max(1, options.threads);
  solver.function_tolerance = options.function_tolerance;
  solver.parameter_tolerance = 1e-9;
  solver.logging_type = ceres::SILENT;
  solver.minimizer_progress_to_stdout = false;
  StopCallback stop(options.stop);
  if (options.stop) solver.callbacks.push_back(&stop);
  ceres::Solver::Summary summary;
  ceres::Solve(solver, &builder.problem(), &summary);
  builder.normalize_quaternions();
  report.stopped = stop.stopped();
  report.converged = summary.termination_type == ceres::CONVERGENCE;
  report.iterations = static_cast<int>(summary.iterations.size());
  const double residuals = std::max(1, summary.num_residuals);
  report.pixel_sigma = builder.pixel_sigma();
  report.loss_scale_px = builder.loss_scale_px();
  report.initial_rms_px =
      report.pixel_sigma * std::sqrt(2 * summary.initial_cost / residuals);
  report.final_rms_px =
      report.pixel_sigma * std::sqrt(2 * summary.final_cost / residuals);
  return report;
}

}  // namespace arscout::engine
