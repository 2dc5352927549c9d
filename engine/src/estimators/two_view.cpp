#include <algorithm>
#include <utility>

#include "estimators/bundle_adjuster.h"
#include "estimators/estimators.h"

#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

namespace arscout::engine {
namespace {

using PointList = std::vector<cv::Point2d>;

PointList to_cv(const std::vector<Eigen::Vector2d>& points) {
  PointList out;
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

cv::Mat essential_of(const Eigen::Matrix3d& R, const Eigen::Vector3d& t) {
  Eigen::Matrix3d t_cross;
  t_cross << 0, -t.z(), t.y(), t.z(), 0, -t.x(), -t.y(), t.x(), 0;
  cv::Mat E;
  cv::eigen2cv(Eigen::Matrix3d(t_cross * R), E);
  return E;
}

// The correspondences within `threshold` (Sampson distance, as OpenCV's
// essential-matrix RANSAC measures it) of E = [t]x R.
cv::Mat sampson_inliers(const cv::Mat& essential, const PointList& p1,
                        const PointList& p2, double threshold) {
  Eigen::Matrix3d E;
  cv::cv2eigen(essential, E);
  cv::Mat mask(static_cast<int>(p1.size()), 1, CV_8U);
  for (size_t i = 0; i < p1.size(); ++i) {
    const Eigen::Vector3d a(p1[i].x, p1[i].y, 1), b(p2[i].x, p2[i].y, 1);
    const Eigen::Vector3d Ea = E * a, Etb = E.transpose() * b;
    const double d = sampson_distance(Ea.data(), Etb.data(), b.data());
    mask.at<uchar>(static_cast<int>(i)) = d * d <= threshold * threshold;
  }
  return mask;
}

// An essential matrix's pose with its inliers in front of both cameras
// (recoverPose's cheirality test on the correspondences `mask` admits).
RelativePose recovered_pose(const cv::Mat& E, const PointList& p1,
                            const PointList& p2, const cv::Mat& inliers) {
  cv::Mat mask = inliers.clone(), R, t;
  cv::recoverPose(E, p1, p2, cv::Mat::eye(3, 3, CV_64F), R, t, mask);
  RelativePose pose;
  cv::cv2eigen(R, pose.R);
  cv::Mat t_unit = t / cv::norm(t);
  cv::cv2eigen(t_unit, pose.t);
  for (int i = 0; i < mask.rows; ++i) {
    if (mask.at<uchar>(i)) pose.inliers.push_back(i);
  }
  return pose;
}

// The essential matrices of a homography's decompositions, one for each
// distinct rotation (the decompositions come in pairs of opposite t).
std::vector<cv::Mat> homography_essentials(const cv::Mat& H) {
  std::vector<cv::Mat> rotations, translations, normals;
  cv::decomposeHomographyMat(H, cv::Mat::eye(3, 3, CV_64F), rotations,
                             translations, normals);
  std::vector<cv::Mat> result;
  std::vector<Eigen::Matrix3d> seen;
  for (size_t k = 0; k < rotations.size(); ++k) {
    Eigen::Matrix3d R;
    Eigen::Vector3d t;
    cv::cv2eigen(rotations[k], R);
    cv::cv2eigen(translations[k], t);
    if (t.norm() < 1e-12) continue;  // a pure rotation: no epipolar geometry
    const bool repeated = std::any_of(seen.begin(), seen.end(),
                                      [&](const Eigen::Matrix3d& other) {
                                        return (R - other).norm() < 1e-9;
                                      });
    if (repeated) continue;
    seen.push_back(R);
    result.push_back(essential_of(R, t.normalized()));
  }
  return result;
}

// A wall filling the view leaves the essential matrix ambiguous: both
// poses its homography decomposes into explain every match on the wall,
// and only the few off it tell them apart. RANSAC stops once a sample of
// wall points gives the wrong one, which already explains most matches
// (docs/engine.md, "Planar scenes"). So the homography's poses are scored
// too, by the matches each explains in front of both cameras, and one that
// explains more than RANSAC's pose replaces it.
RelativePose best_of_planar_candidates(RelativePose ransac, const cv::Mat& H,
                                       const PointList& p1, const PointList& p2,
                                       double threshold) {
  RelativePose best = std::move(ransac);
  for (const cv::Mat& E : homography_essentials(H)) {
    // Its matches in front can only be fewer: most candidates stop here,
    // before the cheirality test's triangulations.
    const cv::Mat inliers = sampson_inliers(E, p1, p2, threshold);
    if (static_cast<size_t>(cv::countNonZero(inliers)) <= best.inliers.size())
      continue;
    RelativePose candidate = recovered_pose(E, p1, p2, inliers);
    if (candidate.inliers.size() > best.inliers.size())
      best = std::move(candidate);
  }
  return best;
}

}  // namespace

std::optional<RelativePose> estimate_relative_pose(
    const std::vector<Eigen::Vector2d>& x1,
    const std::vector<Eigen::Vector2d>& x2, double threshold, int min_inliers) {
  if (x1.size() != x2.size() ||
      static_cast<int>(x1.size()) < std::max(5, min_inliers)) {
    return std::nullopt;
  }
  const PointList p1 = to_cv(x1), p2 = to_cv(x2);
  cv::Mat mask;
  // OpenCV's RANSAC seeds its generator with a constant, so this is
  // deterministic for the same input.
  const cv::Mat E = cv::findEssentialMat(p1, p2, cv::Mat::eye(3, 3, CV_64F),
                                         cv::RANSAC, 0.999, threshold, mask);
  if (E.rows != 3 || E.cols != 3) return std::nullopt;  // none, or several
  RelativePose pose = recovered_pose(E, p1, p2, mask);
  // The degeneracy measure against RANSAC's essential matrix, as before
  // the planar candidates: one of those explains a plane's matches better.
  const size_t ransac_inliers = pose.inliers.size();
  // A pair that fails here pays for no homography (most partners fail).
  if (static_cast<int>(ransac_inliers) < min_inliers) return std::nullopt;
  cv::Mat h_mask;
  const cv::Mat H = cv::findHomography(p1, p2, cv::RANSAC, threshold, h_mask);
  const int h_inliers = h_mask.empty() ? 0 : cv::countNonZero(h_mask);
  // Only where a plane holds most matches can RANSAC's pose be its twin.
  // A candidate replaces it only with more inliers, so min_inliers holds.
  if (!H.empty() && 2 * static_cast<size_t>(h_inliers) >= ransac_inliers)
    pose = best_of_planar_candidates(std::move(pose), H, p1, p2, threshold);
  refine_relative_pose(x1, x2, pose.inliers, &pose.R, &pose.t);
  pose.homography_ratio = static_cast<double>(h_inliers) / ransac_inliers;
  pose.median_angle_deg = median_angle(pose, x1, x2);
  return pose;
}

}  // namespace arscout::engine
