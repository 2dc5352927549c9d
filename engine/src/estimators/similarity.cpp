#include <algorithm>
#include <cmath>
#include <random>

#include <Eigen/Geometry>
#include <Eigen/SVD>

#include "estimators/estimators.h"

namespace arscout::engine {
namespace {

Eigen::Matrix3Xd as_matrix(const std::vector<Eigen::Vector3d>& points,
                           const std::vector<int>& indices) {
  Eigen::Matrix3Xd m(3, indices.size());
  for (size_t i = 0; i < indices.size(); ++i) m.col(i) = points[indices[i]];
  return m;
}

std::vector<int> all_indices(size_t n) {
  std::vector<int> indices(n);
  for (size_t i = 0; i < n; ++i) indices[i] = static_cast<int>(i);
  return indices;
}

std::optional<Similarity> fit_subset(const std::vector<Eigen::Vector3d>& from,
                                     const std::vector<Eigen::Vector3d>& to,
                                     const std::vector<int>& subset) {
  const Eigen::Matrix3Xd a = as_matrix(from, subset);
  const Eigen::Matrix3Xd b = as_matrix(to, subset);
  // Coincident points give no scale or rotation.
  if ((a.colwise() - a.rowwise().mean()).norm() < 1e-12) return std::nullopt;
  const Eigen::Matrix4d T = Eigen::umeyama(a, b, true);
  if (!T.allFinite()) return std::nullopt;
  Similarity s;
  s.scale = T.block<3, 3>(0, 0).col(0).norm();
  if (!(s.scale > 0)) return std::nullopt;
  s.R = T.block<3, 3>(0, 0) / s.scale;
  s.t = T.block<3, 1>(0, 3);
  return s;
}

std::vector<int> inliers_of(const Similarity& s,
                            const std::vector<Eigen::Vector3d>& from,
                            const std::vector<Eigen::Vector3d>& to,
                            double threshold) {
  std::vector<int> inliers;
  for (size_t i = 0; i < from.size(); ++i) {
    if ((s.apply(from[i]) - to[i]).norm() <= threshold) {
      inliers.push_back(static_cast<int>(i));
    }
  }
  return inliers;
}

}  // namespace

std::optional<Similarity> fit_similarity(
    const std::vector<Eigen::Vector3d>& from,
    const std::vector<Eigen::Vector3d>& to) {
  if (from.size() < 3 || from.size() != to.size()) return std::nullopt;
  return fit_subset(from, to, all_indices(from.size()));
}

std::optional<Similarity> estimate_similarity(
    const std::vector<Eigen::Vector3d>& from,
    const std::vector<Eigen::Vector3d>& to, double threshold, uint64_t seed,
    std::vector<int>* inliers_out) {
  const size_t n = from.size();
  if (n < 3 || n != to.size()) return std::nullopt;
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<size_t> pick(0, n - 1);
  std::vector<int> best;
  // Few points (one site's cameras): 200 samples find an all-inlier triple
  // even with half the fixes wrong.
  for (int iteration = 0; iteration < 200; ++iteration) {
    std::vector<int> sample;
    while (sample.size() < 3) {
      const int i = static_cast<int>(pick(rng));
      if (std::find(sample.begin(), sample.end(), i) == sample.end())
        sample.push_back(i);
    }
    const auto candidate = fit_subset(from, to, sample);
    if (!candidate) continue;
    std::vector<int> inliers = inliers_of(*candidate, from, to, threshold);
    if (inliers.size() > best.size()) best = std::move(inliers);
    if (best.size() == n) break;
  }
  if (best.size() < 3) return std::nullopt;
  auto refined = fit_subset(from, to, best);
  if (!refined) return std::nullopt;
  // One more round: the refit may admit points the sample missed.
  std::vector<int> final_inliers = inliers_of(*refined, from, to, threshold);
  if (final_inliers.size() > best.size()) {
    if (auto again = fit_subset(from, to, final_inliers)) {
      refined = again;
      best = std::move(final_inliers);
    }
  }
  if (inliers_out) *inliers_out = best;
  return refined;
}

namespace {

// Least-squares rotation taking from[i] to to[i] over `subset` (Kabsch).
std::optional<Eigen::Matrix3d> fit_rotation(
    const std::vector<Eigen::Vector3d>& from,
    const std::vector<Eigen::Vector3d>& to, const std::vector<int>& subset) {
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  for (int i : subset) H += from[i] * to[i].transpose();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(
      H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  if (!(svd.singularValues()(1) > 1e-12)) return std::nullopt;
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  D(2, 2) =
      (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0 ? -1 : 1;
  const Eigen::Matrix3d R = svd.matrixV() * D * svd.matrixU().transpose();
  if (!R.allFinite()) return std::nullopt;
  return R;
}

std::vector<int> rotation_inliers(const Eigen::Matrix3d& R,
                                  const std::vector<Eigen::Vector3d>& from,
                                  const std::vector<Eigen::Vector3d>& to,
                                  double threshold_rad) {
  const double min_cos = std::cos(threshold_rad);
  std::vector<int> inliers;
  for (size_t i = 0; i < from.size(); ++i) {
    if ((R * from[i]).dot(to[i]) >= min_cos)
      inliers.push_back(static_cast<int>(i));
  }
  return inliers;
}

}  // namespace

std::optional<Eigen::Matrix3d> estimate_rotation(
    const std::vector<Eigen::Vector3d>& from,
    const std::vector<Eigen::Vector3d>& to, double threshold_rad,
    int min_inliers, uint64_t seed, std::vector<int>* inliers_out) {
  const size_t n = from.size();
  if (n < 2 || n != to.size()) return std::nullopt;
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<size_t> pick(0, n - 1);
  std::vector<int> best;
  for (int iteration = 0; iteration < 100; ++iteration) {
    const int a = static_cast<int>(pick(rng));
    const int b = static_cast<int>(pick(rng));
    if (a == b) continue;
    const auto R = fit_rotation(from, to, {a, b});
    if (!R) continue;
    std::vector<int> inliers = rotation_inliers(*R, from, to, threshold_rad);
    if (inliers.size() > best.size()) best = std::move(inliers);
  }
  if (static_cast<int>(best.size()) < std::max(2, min_inliers))
    return std::nullopt;
  const auto refined = fit_rotation(from, to, best);
  if (!refined) return std::nullopt;
  if (inliers_out)
    *inliers_out = rotation_inliers(*refined, from, to, threshold_rad);
  return refined;
}

}  // namespace arscout::engine
