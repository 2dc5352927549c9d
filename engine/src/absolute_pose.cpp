#include "estimators.h"

#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

namespace arscout::engine {

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
  cv::solvePnPRefineLM(inlier_object, inlier_points, K, cv::noArray(), rvec,
                       tvec);
  // Keep every correspondence the refined pose explains.
  std::vector<cv::Point2d> projected;
  cv::projectPoints(object, rvec, tvec, K, cv::noArray(), projected);
  AbsolutePose pose;
  for (size_t i = 0; i < object.size(); ++i) {
    if (cv::norm(projected[i] - points[i]) <= threshold) {
      pose.inliers.push_back(static_cast<int>(i));
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
