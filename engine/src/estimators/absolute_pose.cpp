#include "estimators/estimators.h"

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

}  // namespace arscout::engine
