#include <algorithm>

#include "estimators/bundle_adjuster.h"
#include "estimators/estimators.h"

#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

namespace arscout::engine {
namespace {

std::vector<cv::Point2d> to_cv(const std::vector<Eigen::Vector2d>& points) {
  std::vector<cv::Point2d> out;
  out.reserve(points.size());
  for (const auto& p : points) out.emplace_back(p.x(), p.y());
  return out;
}

double median_angle(const RelativePose& pose,
                    const std::vector<Eigen::Vector2d>& x1,
                    const std::vector<Eigen::Vector2d>& x2) {
  Eigen::Matrix<double, 3, 4> P1 = Eigen::Matrix<double, 3, 4>::Zero();
  P1.leftCols<3>().setIdentity();
  Eigen::Matrix<double, 3, 4> P2;
  P2 << pose.R, pose.t;
  const Eigen::Vector3d c2 = -pose.R.transpose() * pose.t;
  std::vector<double> angles;
  for (int i : pose.inliers) {
    if (auto X = triangulate({P1, P2}, {x1[i], x2[i]})) {
      angles.push_back(
          triangulation_angle_deg(Eigen::Vector3d::Zero(), c2, *X));
    }
  }
  if (angles.empty()) return 0;
  std::nth_element(angles.begin(), angles.begin() + angles.size() / 2,
                   angles.end());
  return angles[angles.size() / 2];
}

}  // namespace

std::optional<RelativePose> estimate_relative_pose(
    const std::vector<Eigen::Vector2d>& x1,
    const std::vector<Eigen::Vector2d>& x2, double threshold, int min_inliers) {
  if (x1.size() != x2.size() ||
      static_cast<int>(x1.size()) < std::max(5, min_inliers)) {
    return std::nullopt;
  }
  const std::vector<cv::Point2d> p1 = to_cv(x1), p2 = to_cv(x2);
  cv::Mat mask;
  // OpenCV's RANSAC seeds its generator with a constant, so this is
  // deterministic for the same input.
  const cv::Mat E = cv::findEssentialMat(p1, p2, cv::Mat::eye(3, 3, CV_64F),
                                         cv::RANSAC, 0.999, threshold, mask);
  if (E.rows != 3 || E.cols != 3) return std::nullopt;  // none, or several
  cv::Mat R, t;
  const int in_front =
      cv::recoverPose(E, p1, p2, cv::Mat::eye(3, 3, CV_64F), R, t, mask);
  if (in_front < min_inliers) return std::nullopt;
  RelativePose pose;
  cv::cv2eigen(R, pose.R);
  cv::Mat t_unit = t / cv::norm(t);
  cv::cv2eigen(t_unit, pose.t);
  for (int i = 0; i < mask.rows; ++i) {
    if (mask.at<uchar>(i)) pose.inliers.push_back(i);
  }
  refine_relative_pose(x1, x2, pose.inliers, &pose.R, &pose.t);
  cv::Mat h_mask;
  cv::findHomography(p1, p2, cv::RANSAC, threshold, h_mask);
  const int h_inliers = h_mask.empty() ? 0 : cv::countNonZero(h_mask);
  pose.homography_ratio = static_cast<double>(h_inliers) / pose.inliers.size();
  pose.median_angle_deg = median_angle(pose, x1, x2);
  return pose;
}

}  // namespace arscout::engine
