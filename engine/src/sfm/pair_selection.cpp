#include "sfm/pair_selection.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <map>

#include "features/matcher.h"
#include "runtime/parallel.h"

namespace arscout::engine {
namespace {

// The visual screen: how many descriptors of a new image it samples, how
// many of those must match for a photo to count as overlapping, and how
// many earlier photos it looks at (the most recent).
constexpr int kScreenSamples = 256;
constexpr int kScreenMinimum = 12;
constexpr int kScreenMaxImages = 60;
// Spatial partners that match fewer sampled descriptors than this are not
// matched in full (pairs that verify match several times more).
constexpr int kSpatialScreen = 4;
// Every other partner (the scout's recent photos, the baseline bands, the
// photos sharing points) must match at least this many: on seed 31's block
// walk, of 115 partners below it none verified, and they were a third of
// the full matches (docs/engine.md, "Matching").
constexpr int kPartnerScreen = 2;
// Old captures near a new one screened for a loop.
constexpr int kLoopScreen = 8;
// Registered captures closer than this fraction of the scene's depth and
// turned less than this are near duplicates as match partners.
constexpr double kDuplicateBaseline = 0.01;
constexpr double kDuplicateAngleRad = 2.0 * M_PI / 180;

// The median depth of the points a registered image observes (0 for none).
double median_depth(const Scene& scene, int index) {
  const SceneImage& image = scene.images[index];
  std::vector<double> depths;
  for (int64_t point : image.point_of) {
    if (point < 0) continue;
    depths.push_back((image.q * scene.points.at(point).xyz + image.t).z());
  }
  if (depths.empty()) return 0;
  std::nth_element(depths.begin(), depths.begin() + depths.size() / 2,
                   depths.end());
  return depths[depths.size() / 2];
}

}  // namespace

// Where a capture is believed to be: its place in the model once the model
// is in ENU, else its fix.
Eigen::Vector3d believed_position(const Scene& scene, int index) {
  const SceneImage& image = scene.images[index];
  if (image.registered && scene.geo_registered) return image.centre();
  return image.gps_enu;
}

// Two registered captures from (almost) the same place looking (almost) the
// same way: matching a new photo against both adds nothing the first gives.
bool PairSelector::near_duplicate(int a, int b) const {
  const SceneImage& x = scene.images[a];
  const SceneImage& y = scene.images[b];
  if (!x.registered || !y.registered) return false;
  const double depth = depth_of(a);
  if (!(depth > 0)) return false;
  return (x.centre() - y.centre()).norm() < kDuplicateBaseline * depth &&
         x.q.angularDistance(y.q) < kDuplicateAngleRad;
}

double PairSelector::depth_of(int index) const {
  auto [at, added] = depth_memo.try_emplace(index, 0.0);
  if (added) at->second = median_depth(scene, index);
  return at->second;
}

// Earlier captures with a fix by distance from `index`'s fix (within the
// radius), nearest first.
std::vector<std::pair<double, int>> PairSelector::by_distance(int index) const {
  std::vector<std::pair<double, int>> result;
  const SceneImage& image = scene.images[index];
  for (int i = 0; i < index; ++i) {
    const SceneImage& other = scene.images[i];
    if (other.removed || !other.gps) continue;
    const double d =
        (believed_position(scene, i) - image.gps_enu).head<2>().norm();
    if (d <= options.gps_radius_m) result.push_back({d, i});
  }
  std::sort(result.begin(), result.end());
  return result;
}

// Adds to `chosen` the spatial partners of a capture with a fix: the
// nearest (none a near duplicate of one chosen), the nearest in each
// baseline band (parallax), and the nearest old ones (loops). At most gps +
// baseline + loop neighbours more.
std::set<int> PairSelector::spatial_neighbours(int index,
                                               std::set<int> chosen) const {
  const auto ranked = by_distance(index);
  int nearest = 0;
  for (const auto& [d, i] : ranked) {
    if (nearest >= options.gps_neighbours) break;
    if (chosen.count(i)) continue;
    const int candidate = i;  // lambdas may not capture bindings (C++20)
    const bool duplicate = std::any_of(
        chosen.begin(), chosen.end(),
        [&](int other) { return near_duplicate(candidate, other); });
    if (duplicate) continue;
    chosen.insert(i);
    ++nearest;
  }
  double band = options.baseline_min_m;
  for (int b = 0; b < options.baseline_neighbours; ++b, band *= 2) {
    for (const auto& [d, i] : ranked) {
      if (d < band || d >= 2 * band || chosen.count(i)) continue;
      chosen.insert(i);
      break;
    }
  }
  for (int i : loop_candidates(index, ranked, chosen)) chosen.insert(i);
  return chosen;
}

// Old captures near `index` (a walk that came back to where it was): the
// nearest few by position, no two near duplicates, screened by appearance;
// the `loop_neighbours` best that pass the screen.
std::vector<int> PairSelector::loop_candidates(
    int index, const std::vector<std::pair<double, int>>& ranked,
    const std::set<int>& chosen) const {
  std::vector<int> screened;
  std::vector<std::pair<int, int>> scored;  // (-score, image)
  for (const auto& [d, i] : ranked) {
    if (static_cast<int>(screened.size()) >= kLoopScreen) break;
    if (index - i <= options.loop_min_age || chosen.count(i)) continue;
    const int candidate = i;  // lambdas may not capture bindings (C++20)
    if (std::any_of(screened.begin(), screened.end(), [&](int other) {
          return near_duplicate(candidate, other);
        }))
      continue;
    screened.push_back(i);
  }
  const std::vector<int> scores = overlaps(index, screened);
  for (size_t k = 0; k < screened.size(); ++k)
    if (scores[k] >= kScreenMinimum)
      scored.push_back({-scores[k], screened[k]});
  std::sort(scored.begin(), scored.end());
  std::vector<int> result;
  for (size_t k = 0;
       k < scored.size() && static_cast<int>(k) < options.loop_neighbours;
       ++k) {
    result.push_back(scored[k].second);
  }
  return result;
}

// The spatial partners, the captures its scout added just before (several
// scouts upload at once), registered captures that share points with
// those, and the best of a cheap visual screen over the rest (which also
// finds photos turned sideways or upside down): never all pairs.
std::vector<Candidate> PairSelector::neighbours(int index) const {
  const SceneImage& image = scene.images[index];
  std::set<int> chosen;
  int recent = 0;
  for (int i = index - 1; i >= 0 && recent < options.recent_neighbours; --i) {
    if (scene.images[i].removed || scene.images[i].scout != image.scout)
      continue;
    chosen.insert(i);
    ++recent;
  }
  std::map<int, int> scores;  // of the screen, by partner
  const auto screen = [&](const std::set<int>& others) {
    std::vector<int> missing;
    for (int other : others)
      if (!scores.count(other)) missing.push_back(other);
    const std::vector<int> found = overlaps(index, missing);
    for (size_t k = 0; k < missing.size(); ++k) scores[missing[k]] = found[k];
  };
  const auto score = [&](int other) { return scores.at(other); };
  if (image.gps) {
    const std::set<int> recent_ones = chosen;
    const std::set<int> spatial = spatial_neighbours(index, chosen);
    chosen = recent_ones;
    std::set<int> new_ones;
    std::set_difference(spatial.begin(), spatial.end(), recent_ones.begin(),
                        recent_ones.end(),
                        std::inserter(new_ones, new_ones.end()));
    screen(new_ones);
    // Nearby by a noisy fix is not overlapping: a photo of the other side
    // of the street costs a full match and gives nothing.
    for (int other : spatial) {
      if (!recent_ones.count(other) && score(other) >= kSpatialScreen)
        chosen.insert(other);
    }
  }
  for (int other : covisible_with(chosen)) chosen.insert(other);
  // A photo with a fix is matched upright against its neighbours; one
  // without is screened against the recent photos of the site, in all four
  // quarter turns.
  std::vector<Candidate> result;
  if (image.gps) {
    screen(chosen);
    for (int other : chosen) {
      if (score(other) >= kPartnerScreen) result.push_back({other, 0});
    }
    return result;
  }
  for (int other : chosen)
    result.push_back({other, best_rotation(index, other).first});
  for (const Candidate& c : visual_screen(index, chosen)) result.push_back(c);
  return result;
}

// The rows of the strongest `match_features` corners: the only ones an
// increment matches (the weaker ones are the refinement's, sfm/densify.cpp).
cv::Mat matched_descriptors(const Scene& scene,
                            const ReconstructionOptions& options, int index) {
  const cv::Mat& all = scene.images[index].descriptors;
  return all.rowRange(0, std::min(all.rows, options.match_features));
}

// How many sampled descriptors of `index` match `other` upright.
int PairSelector::overlap(int index, int other) const {
  return overlap_score(matched_descriptors(scene, options, index),
                       matched_descriptors(scene, options, other),
                       options.ratio, kScreenSamples);
}

// overlap() of `index` with each of `others`, several at once on up to
// options.threads cores.
std::vector<int> PairSelector::overlaps(int index,
                                        const std::vector<int>& others) const {
  std::vector<int> result(others.size(), 0);
  run_tasks(others.size(), options.threads,
            [&](size_t k) { result[k] = overlap(index, others[k]); });
  return result;
}

// Registered images that share the most points with `images`.
std::vector<int> PairSelector::covisible_with(
    const std::set<int>& images) const {
  std::map<int, int> shared;
  for (int i : images) {
    for (int64_t point : scene.images[i].point_of) {
      if (point < 0) continue;
      for (const Observation& obs : scene.points.at(point).track) {
        if (!images.count(obs.image)) ++shared[obs.image];
      }
    }
  }
  std::vector<std::pair<int, int>> ranked;
  for (const auto& [other, count] : shared) ranked.push_back({-count, other});
  std::sort(ranked.begin(), ranked.end());
  std::vector<int> result;
  for (size_t i = 0;
       i < ranked.size() && static_cast<int>(i) < options.visual_neighbours;
       ++i) {
    result.push_back(ranked[i].second);
  }
  return result;
}

// The quarter turns under which `index` best matches `other`, and the
// screen's score; upright first, turned only when upright finds little.
std::pair<int, int> PairSelector::best_rotation(int index, int other) const {
  const cv::Mat mine = matched_descriptors(scene, options, index);
  const cv::Mat theirs = matched_descriptors(scene, options, other);
  std::pair<int, int> best{
      0, overlap_score(mine, theirs, options.ratio, kScreenSamples)};
  if (best.second >= kScreenMinimum) return best;
  for (int turns = 1; turns < 4; ++turns) {
    const int score = overlap_score(rotate_descriptors(mine, turns), theirs,
                                    options.ratio, kScreenSamples);
    if (score > best.second) best = {turns, score};
  }
  return best;
}

std::vector<Candidate> PairSelector::visual_screen(
    int index, const std::set<int>& skip) const {
  std::vector<std::pair<int, Candidate>> scored;
  int screened = 0;
  for (int i = index - 1; i >= 0 && screened < kScreenMaxImages; --i) {
    if (scene.images[i].removed || skip.count(i)) continue;
    ++screened;
    const auto [turns, score] = best_rotation(index, i);
    if (score >= kScreenMinimum) scored.push_back({-score, {i, turns}});
  }
  std::sort(scored.begin(), scored.end(), [](const auto& x, const auto& y) {
    return x.first != y.first ? x.first < y.first
                              : x.second.image < y.second.image;
  });
  std::vector<Candidate> result;
  for (size_t i = 0;
       i < scored.size() && static_cast<int>(i) < options.visual_neighbours;
       ++i) {
    result.push_back(scored[i].second);
  }
  return result;
}

}  // namespace arscout::engine
