#include <algorithm>
#include <cmath>

#include <Eigen/SVD>

#include "estimators.h"

namespace arscout::engine {

std::optional<Eigen::Vector3d> triangulate(
    const std::vector<Eigen::Matrix<double, 3, 4>>& poses,
    const std::vector<Eigen::Vector2d>& points) {
  if (poses.size() < 2 || poses.size() != points.size()) return std::nullopt;
  Eigen::MatrixXd A(2 * poses.size(), 4);
  for (size_t i = 0; i < poses.size(); ++i) {
    A.row(2 * i) = points[i].x() * poses[i].row(2) - poses[i].row(0);
    A.row(2 * i + 1) = points[i].y() * poses[i].row(2) - poses[i].row(1);
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(A, Eigen::ComputeFullV);
  const Eigen::Vector4d X = svd.matrixV().col(3);
  if (std::abs(X(3)) < 1e-12) return std::nullopt;
  return Eigen::Vector3d(X.head<3>() / X(3));
}

double triangulation_angle_deg(const Eigen::Vector3d& centre1,
                               const Eigen::Vector3d& centre2,
                               const Eigen::Vector3d& point) {
  const Eigen::Vector3d r1 = (centre1 - point).normalized();
  const Eigen::Vector3d r2 = (centre2 - point).normalized();
  return std::acos(std::clamp(r1.dot(r2), -1.0, 1.0)) * 180.0 / M_PI;
}

}  // namespace arscout::engine
