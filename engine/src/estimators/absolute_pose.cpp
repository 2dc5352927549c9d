#include "estimators/estimators.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

namespace arscout::engine {
namespace {

// The correspondences a pose projects within `threshold` (normalized).
std::vector<int> explained(const std::vector<cv::Point3d>& object,
                           const std::vector<cv::Point2d>& points,
                           const cv::Mat& rvec, const cv::Mat& tvec,
                           double threshold) {
  std::vector<cv::Point2d> projected;
  const cv::Mat K = cv::Mat::eye(3, 3, CV_64F);
  cv::projectPoints(object, rvec, tvec, K, cv::noArray(), projected);
  std::vector<int> result;
  for (size_t i = 0; i < object.size(); ++i) {
    if (cv::norm(projected[i] - points[i]) <= threshold)
      result.push_back(static_cast<int>(i));
  }
  return result;
}

}  // namespace

std::optional<AbsolutePose> estimate_absolute_pose(
    const std::vector<Eigen::Vector3d>& world,
    const std::vector<Eigen::Vector2d>& image, double threshold,
    int min_inliers) {
  if (world.size() != image.size() ||
      static_cast<int>(world.size()) < std::max(4, min_inliers)) {
    return std::nullopt;
  }
  std::vector<cv::Point3d> object;
  std::vector<cv::Point2d> points;
  for (size_t i = 0; i < world.size(); ++i) {
    object.emplace_back(world[i].x(), world[i].y(), world[i].z());
    points.emplace_back(image[i].x(), image[i].y());
  }
  const cv::Mat K = cv::Mat::eye(3, 3, CV_64F);
  cv::Mat rvec, tvec;
  std::vector<int> inliers;
  // Minimal P3P hypotheses (AP3P, Ke and Roumeliotis 2017); OpenCV seeds its
  // RANSAC generator with a constant, so this is deterministic.
  const bool found =
      cv::solvePnPRansac(object, points, K, cv::noArray(), rvec, tvec, false,
                         2000, threshold, 0.9999, inliers, cv::SOLVEPNP_AP3P);
  if (!found || static_cast<int>(inliers.size()) < min_inliers)
    return std::nullopt;
  std::vector<cv::Point3d> inlier_object;
  std::vector<cv::Point2d> inlier_points;
  for (int i : inliers) {
    inlier_object.push_back(object[i]);
    inlier_points.push_back(points[i]);
  }
  // OpenCV ends its P3P RANSAC with EPnP on the inliers, which is unstable
  // when they lie on one plane (a wall seen square on): it can land many
  // degrees off, in the mirror minimum of the planar pose ambiguity, where
  // the refinement below stays. SQPnP finds the global minimum for any
  // configuration; the pose explaining more correspondences is kept.
  // OpenCV 4.6's SQPnP asserts (computeOmega: more than 6 null vectors) on
  // degenerate inliers, e.g. many of them on one line: the RANSAC pose
  // stands alone then. Uncaught, the assertion failed the whole increment,
  // and its retry again, for good (a 400-photo walk stuck at photo 192).
  cv::Mat sq_rvec, sq_tvec;
  try {
    if (cv::solvePnP(inlier_object, inlier_points, K, cv::noArray(), sq_rvec,
                     sq_tvec, false, cv::SOLVEPNP_SQPNP)) {
      cv::solvePnPRefineLM(inlier_object, inlier_points, K, cv::noArray(),
                           sq_rvec, sq_tvec);
    }
  } catch (const cv::Exception&) {
    sq_rvec.release();
    sq_tvec.release();
  }
  cv::solvePnPRefineLM(inlier_object, inlier_points, K, cv::noArray(), rvec,
                       tvec);
  AbsolutePose pose;
  pose.inliers = explained(object, points, rvec, tvec, threshold);
  if (!sq_rvec.empty()) {
    std::vector<int> sq_inliers =
        explained(object, points, sq_rvec, sq_tvec, threshold);
    if (sq_inliers.size() > pose.inliers.size()) {
      pose.inliers = std::move(sq_inliers);
      rvec = sq_rvec;
      tvec = sq_tvec;
    }
  }
  if (static_cast<int>(pose.inliers.size()) < min_inliers) return std::nullopt;
  cv::Mat R;
  cv::Rodrigues(rvec, R);
  Eigen::Matrix3d R_eigen;
  cv::cv2eigen(R, R_eigen);
  pose.q = Eigen::Quaterniond(R_eigen).normalized();
  cv::cv2eigen(tvec, pose.t);
  // Points behind the camera are not explained, whatever their projection.
  std::erase_if(pose.inliers,
                [&](int i) { return (pose.q * world[i] + pose.t).z() <= 0; });
  if (static_cast<int>(pose.inliers.size()) < min_inliers) return std::nullopt;
  return pose;
}

// Gauss-Newton information of the reprojection errors with respect to a
// rotation increment and a translation increment in the camera frame
// (Xc' = (I + [w]x) Xc + dt); its inverse is the pose's covariance.
PoseUncertainty pose_uncertainty(const Eigen::Quaterniond& q,
                                 const Eigen::Vector3d& t,
                                 const std::vector<Eigen::Vector3d>& world,
                                 double image_sigma) {
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Zero();
  for (const Eigen::Vector3d& x : world) {
    const Eigen::Vector3d c = q * x + t;
    if (c.z() <= 1e-9) continue;
    Eigen::Matrix<double, 2, 3> projection;
    projection << 1 / c.z(), 0, -c.x() / (c.z() * c.z()), 0, 1 / c.z(),
        -c.y() / (c.z() * c.z());
    Eigen::Matrix<double, 3, 6> motion;
    motion.leftCols<3>() << 0, c.z(), -c.y(), -c.z(), 0, c.x(), c.y(), -c.x(),
        0;
    motion.rightCols<3>().setIdentity();
    const Eigen::Matrix<double, 2, 6> jacobian = projection * motion;
    information += jacobian.transpose() * jacobian;
  }
  PoseUncertainty result;
  const Eigen::FullPivLU<Eigen::Matrix<double, 6, 6>> lu(information);
  if (!lu.isInvertible()) return result;  // infinite: unconstrained
  const Eigen::Matrix<double, 6, 6> covariance =
      lu.inverse() * image_sigma * image_sigma;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> rotation(
      covariance.topLeftCorner<3, 3>());
  // To first order the centre C = -R^T t moves by -R^T dt alone (the
  // rotation's share cancels), so the translation block, rotated, is the
  // centre's covariance, with the same eigenvalues.
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> translation(
      covariance.bottomRightCorner<3, 3>());
  result.rotation_sigma_rad =
      std::sqrt(std::max(0.0, rotation.eigenvalues().maxCoeff()));
  result.translation_sigma =
      std::sqrt(std::max(0.0, translation.eigenvalues().maxCoeff()));
  return result;
}

}  // namespace arscout::engine
