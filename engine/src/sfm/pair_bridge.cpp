// Merging two components through one verified pair across them: each of
// its photos is posed in its own component, and the pair's relative pose
// (its rotation and the direction of its baseline, from the two-view
// geometry the increments verified) ties the two frames together. What the
// pair cannot say, its baseline's length, each side's points fix in that
// side's units: a match whose keypoint holds a point of the side has one
// depth there and one, up to the baseline's length, in the pair. Where two
// walks meet, the photos on either side often share too few triangulated
// points for a photo to be posed in the other component (a phone's walk
// keeps 50-60 points a photo), while their pair holds hundreds of matches
// (docs/engine.md, "Merging components").
#include <algorithm>
#include <cmath>
#include <optional>
#include <vector>

#include "sfm/mapper.h"

namespace arscout::engine {
namespace {

// Depth ratios a side must give, and how far from their median (as a share
// of it) they must lie to count as agreeing. Triangulated depths from a
// baseline of a few metres are good to a fraction of a percent; a tenth
// leaves room for the loose keypoints of phone photos and refuses a pair
// whose relative pose does not hold.
constexpr int kMinScaleSamples = 6;
constexpr double kScaleAgreement = 0.1;
// A bridge pair's parallax, degrees: below it the baseline's direction,
// hence the similarity's translation, is poorly fixed.
constexpr double kMinBridgeAngleDeg = 2.0;
// The similarity's scale, either way, at most this factor.
constexpr double kBridgeScaleRange = 5;
// Keypoints of the other side's points tried two by two for a camera
// centre: a pair bridge names a few dozen at most.
constexpr size_t kMaxCentreSamples = 40;

// The geometric mean of the ratios within kScaleAgreement of their median,
// when at least kMinScaleSamples and two thirds of them agree.
std::optional<double> agreed_ratio(std::vector<double> ratios) {
  if (static_cast<int>(ratios.size()) < kMinScaleSamples) return std::nullopt;
  std::nth_element(ratios.begin(), ratios.begin() + ratios.size() / 2,
                   ratios.end());
  const double median = ratios[ratios.size() / 2];
  if (!(median > 0)) return std::nullopt;
  double log_sum = 0;
  int agreeing = 0;
  for (double r : ratios) {
    if (std::abs(r / median - 1) > kScaleAgreement) continue;
    log_sum += std::log(r);
    ++agreeing;
  }
  if (agreeing < kMinScaleSamples ||
      3 * agreeing < 2 * static_cast<int>(ratios.size()))
    return std::nullopt;
  return std::exp(log_sum / agreeing);
}

// The camera centre c that puts each point where its ray says, the
// camera's rotation R (world to camera) given: R (X - c) is parallel to
// (x, y, 1), two linear equations in c a point, solved in least squares.
std::optional<Eigen::Vector3d> centre_from_rays(
    const Eigen::Matrix3d& R,
    const std::vector<std::pair<Eigen::Vector2d, Eigen::Vector3d>>& rays) {
  Eigen::MatrixXd A(2 * rays.size(), 3);
  Eigen::VectorXd b(2 * rays.size());
  for (size_t row = 0; row < rays.size(); ++row) {
    const Eigen::Vector2d& x = rays[row].first;
    const Eigen::Vector3d v = R * rays[row].second;
    // With w = R c: (v - w) x (x, y, 1) = 0, its first two rows.
    A.row(2 * row) << 1, 0, -x.x();
    A.row(2 * row + 1) << 0, 1, -x.y();
    b(2 * row) = v.x() - x.x() * v.z();
    b(2 * row + 1) = v.y() - x.y() * v.z();
  }
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(A);
  if (qr.rank() < 3) return std::nullopt;
  return R.transpose() * Eigen::Vector3d(qr.solve(b));
}

}  // namespace

std::vector<std::pair<int, int>> IncrementalMapper::pairs_across(int a,
                                                                 int b) const {
  std::vector<std::pair<size_t, std::pair<int, int>>> ranked;
  for (const auto& [key, pair] : scene_.pairs) {
    const SceneImage& x = scene_.images[key.first];
    const SceneImage& y = scene_.images[key.second];
    if (!x.registered || !y.registered) continue;
    if ((x.component == a && y.component == b) ||
        (x.component == b && y.component == a))
      ranked.push_back({pair.matches.size(), key});
  }
  std::sort(ranked.begin(), ranked.end(),
            [](const auto& l, const auto& r) { return l.first > r.first; });
  std::vector<std::pair<int, int>> result;
  for (const auto& entry : ranked) result.push_back(entry.second);
  return result;
}

// The similarity from the second photo's component to the first's that the
// pair `key` gives, or none when either side's points do not agree on the
// baseline's length, or the other side's points, taken through it, miss
// their keypoints in the photo on this side.
std::optional<Similarity> IncrementalMapper::similarity_through_pair(
    const std::pair<int, int>& key) const {
  const ImagePair& pair = scene_.pairs.at(key);
  const auto sim = pair.median_angle_deg >= kMinBridgeAngleDeg
                       ? similarity_by_baseline(key)
                       : similarity_by_rotation(key);
  if (!sim ||
      !(sim->scale > 1 / kBridgeScaleRange && sim->scale < kBridgeScaleRange) ||
      !bridge_reprojects(key, *sim))
    return std::nullopt;
  return sim;
}

// The baseline's length on either side from the depths of its points.
std::optional<Similarity> IncrementalMapper::similarity_by_baseline(
    const std::pair<int, int>& key) const {
  const ImagePair& pair = scene_.pairs.at(key);
  const SceneImage& first = scene_.images[key.first];
  const SceneImage& second = scene_.images[key.second];
  // The pair's own frame: the first camera at the origin, a unit baseline.
  SceneImage first_local, second_local;
  second_local.q = Eigen::Quaterniond(pair.R).normalized();
  second_local.t = pair.t;
  std::vector<double> first_ratios, second_ratios;
  for (const auto& [kf, ks] : pair.matches) {
    const int64_t pf = first.point_of[kf];
    const int64_t ps = second.point_of[ks];
    if (pf < 0 && ps < 0) continue;
    const auto X = triangulated(first_local, {key.first, kf}, second_local,
                                {key.second, ks});
    if (!X) continue;
    if (pf >= 0) {
      const Eigen::Vector3d own = first.q * scene_.points.at(pf).xyz + first.t;
      first_ratios.push_back(own.z() / X->z());
    }
    if (ps >= 0) {
      const Eigen::Vector3d own =
          second.q * scene_.points.at(ps).xyz + second.t;
      second_ratios.push_back(own.z() / (second_local.q * *X + pair.t).z());
    }
  }
  const auto first_length = agreed_ratio(first_ratios);
  const auto second_length = agreed_ratio(second_ratios);
  if (!first_length || !second_length) return std::nullopt;
  // The second camera in the first's component: the pair's pose after the
  // first's, its baseline at the first side's length.
  const Eigen::Matrix3d R_there = pair.R * first.q.toRotationMatrix();
  const Eigen::Vector3d t_there = pair.R * first.t + *first_length * pair.t;
  // A point x of the second's component: camera coordinates R x + t in its
  // units, times `scale` in the first's, back through the pose there.
  Similarity sim;
  sim.scale = *first_length / *second_length;
  sim.R = R_there.transpose() * second.q.toRotationMatrix();
  sim.t = R_there.transpose() * (sim.scale * second.t - t_there);
  return sim;
}

// A pair with too little parallax to fix its baseline's direction (two
// photos from about one spot, as where a scout turns) still fixes the
// rotation between the frames; there the essential matrix's rotation is
// loose too, so the turn is fitted to the rays themselves where most of
// them agree with one. Scale comes from the matches whose keypoints hold a
// point on both sides: from one spot a place is as far from both cameras.
// The first camera's centre in the second's frame then comes from its
// keypoints of the second's points at that rotation (centre_at_rotation):
// the places' own offsets would carry their depth errors, metres for a
// young component's points, where the keypoints fix the centre to
// centimetres.
std::optional<Similarity> IncrementalMapper::similarity_by_rotation(
    const std::pair<int, int>& key) const {
  const ImagePair& pair = scene_.pairs.at(key);
  const SceneImage& first = scene_.images[key.first];
  const SceneImage& second = scene_.images[key.second];
  const auto turn = turn_rotation(key.second, key.first, pair);
  // World of the second's component to the first camera.
  const Eigen::Matrix3d first_there =
      (turn ? *turn : pair.R).transpose() * second.q.toRotationMatrix();
  std::vector<double> ratios;
  for (const auto& [kf, ks] : pair.matches) {
    const int64_t pf = first.point_of[kf];
    const int64_t ps = second.point_of[ks];
    if (pf < 0 || ps < 0) continue;
    const double far_there =
        (second.q * scene_.points.at(ps).xyz + second.t).norm();
    if (far_there > 0)
      ratios.push_back((first.q * scene_.points.at(pf).xyz + first.t).norm() /
                       far_there);
  }
  const auto scale = agreed_ratio(ratios);
  const auto centre_there = centre_at_rotation(key, first_there);
  if (!scale || !centre_there) return std::nullopt;
  Similarity sim;
  sim.scale = *scale;
  sim.R = first.q.toRotationMatrix().transpose() * first_there;
  sim.t = first.centre() - sim.scale * (sim.R * *centre_there);
  return sim;
}

// Where the first photo of the pair stands in the second's component, its
// rotation there given: the centre that the most of its keypoints of the
// second's points agree on within the model's reprojection limit (each two
// of them fix one, linearly), refitted to those. None with fewer than two.
std::optional<Eigen::Vector3d> IncrementalMapper::centre_at_rotation(
    const std::pair<int, int>& key, const Eigen::Matrix3d& R) const {
  const ImagePair& pair = scene_.pairs.at(key);
  const SceneImage& first = scene_.images[key.first];
  const SceneImage& second = scene_.images[key.second];
  const SceneCamera& camera = scene_.cameras[first.camera];
  std::vector<std::pair<int, int64_t>> corr;  // first's keypoint, point
  for (const auto& [kf, ks] : pair.matches)
    if (second.point_of[ks] >= 0) corr.emplace_back(kf, second.point_of[ks]);
  const auto rays_of = [&](const std::vector<std::pair<int, int64_t>>& some) {
    std::vector<std::pair<Eigen::Vector2d, Eigen::Vector3d>> rays;
    for (const auto& [keypoint, point] : some)
      rays.emplace_back(normalize(camera, first.keypoints[keypoint]),
                        scene_.points.at(point).xyz);
    return rays;
  };
  const Eigen::Quaterniond q = Eigen::Quaterniond(R).normalized();
  std::optional<Eigen::Vector3d> best;
  std::vector<std::pair<int, int64_t>> best_agreeing;
  const size_t n = std::min(corr.size(), kMaxCentreSamples);
  for (size_t i = 0; i < n; ++i) {
    for (size_t j = i + 1; j < n; ++j) {
      const auto centre = centre_from_rays(R, rays_of({corr[i], corr[j]}));
      if (!centre) continue;
      auto explained = agreeing_matches(key.first, q, *centre, corr);
      if (explained.size() > best_agreeing.size()) {
        best = centre;
        best_agreeing = std::move(explained);
      }
    }
  }
  if (best_agreeing.size() < 2) return std::nullopt;
  const auto refitted = centre_from_rays(R, rays_of(best_agreeing));
  return refitted && agreeing_matches(key.first, q, *refitted, corr).size() >=
                         best_agreeing.size()
             ? refitted
             : best;
}

// Whether the second photo's points that the pair's matches name, moved by
// `sim` into the first's frame, land on their keypoints in the first photo
// (within the model's reprojection limit), at least kMinScaleSamples and
// two thirds of them. The depth ratios alone cannot tell a rotation that
// is off: it moves every point sideways, not nearer.
bool IncrementalMapper::bridge_reprojects(const std::pair<int, int>& key,
                                          const Similarity& sim) const {
  const ImagePair& pair = scene_.pairs.at(key);
  const SceneImage& first = scene_.images[key.first];
  const SceneImage& second = scene_.images[key.second];
  const SceneCamera& camera = scene_.cameras[first.camera];
  int tried = 0, landed = 0;
  for (const auto& [kf, ks] : pair.matches) {
    const int64_t ps = second.point_of[ks];
    if (ps < 0) continue;
    ++tried;
    Eigen::Vector2d pixel;
    landed +=
        project(camera, first, sim.apply(scene_.points.at(ps).xyz), &pixel) &&
        (pixel - first.keypoints[kf]).norm() <= options_.max_reprojection_px;
  }
  return landed >= kMinScaleSamples && 3 * landed >= 2 * tried;
}

std::optional<Similarity> IncrementalMapper::pair_similarity(int keep,
                                                             int gone) const {
  for (const auto& key : pairs_across(keep, gone)) {
    const auto second_to_first = similarity_through_pair(key);
    if (!second_to_first) continue;
    return scene_.images[key.first].component == keep
               ? *second_to_first
               : second_to_first->inverse();
  }
  return std::nullopt;
}

}  // namespace arscout::engine
