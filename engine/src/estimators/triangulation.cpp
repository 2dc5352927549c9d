#include <algorithm>
#include <cmath>

#include <Eigen/SVD>

#include "estimators/estimators.h"

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
  // Rays that coincide (cameras in one place) leave a family of solutions:
  // the second-smallest singular value vanishes.
  const Eigen::VectorXd& sigma = svd.singularValues();
  if (sigma(2) <= 1e-9 * sigma(0)) return std::nullopt;
  const Eigen::Vector4d X = svd.matrixV().col(3);
  if (std::abs(X(3)) < 1e-12) return std::nullopt;
  const Eigen::Vector3d point = X.head<3>() / X(3);
  for (const auto& pose : poses) {
    if ((pose.leftCols<3>() * point + pose.col(3)).z() <= 0)
      return std::nullopt;
  }
  return point;
}

double triangulation_angle_deg(const Eigen::Vector3d& centre1,
                               const Eigen::Vector3d& centre2,
                               const Eigen::Vector3d& point) {
  const Eigen::Vector3d r1 = centre1 - point;
  const Eigen::Vector3d r2 = centre2 - point;
  // atan2 stays exact for the small angles that matter here; acos does not.
  return std::atan2(r1.cross(r2).norm(), r1.dot(r2)) * 180.0 / M_PI;
}

}  // namespace arscout::engine
