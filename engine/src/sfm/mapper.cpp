#include "sfm/mapper.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <set>

#include "estimators/bundle_adjuster.h"
#include "estimators/estimators.h"
#include "features/keypoint_refinement.h"
#include "runtime/stopwatch.h"
#include "sfm/fixes.h"
#include "sfm/loop_closure.h"

#include <Eigen/Eigenvalues>

namespace arscout::engine {
namespace {

constexpr int kGlobalIterations = 30;

// P3P with fewer inliers than this gets a second opinion from the
// neighbour's relative pose (register_from_pair's hypotheses).
constexpr int kConfidentInliers = 60;

// Below this baseline, as a fraction of the scene's depth (about 0.6
// degrees of parallax), a new view refines only its own pose.
constexpr double kKeyViewBaseline = 0.01;
constexpr double kKeyViewAngleRad = 5.0 * M_PI / 180;
// Observations per point in the global refinement (spread along a track):
// a point seen by a hundred photos of a burst is fixed well by 25.
constexpr int kGlobalTrack = 25;
// A long walk bends along soft modes (a gentle curl of the whole loop) that
// change the cost by less than Ceres' default 1e-6 per iteration: the
// refinement, off the latency path, keeps going where an inline adjustment
// would stop (400-photo walk: 4.8 -> 2.9 cm; docs/engine.md).
constexpr double kRefineTolerance = 1e-10;
// The adjustments on the latency path stop once an iteration gains less than
// this share of the cost. A local adjustment took 99 % of its gain in its
// first four iterations and always ran all fifteen; an inline global one
// gains a few parts in 10^4 in all, most of it creeping along soft modes
// that the refinement, off the latency path, follows to the end. 3e-4 for
// the local one cost the site-merge test 0.5 cm; 1e-4 did not.
constexpr double kLocalTolerance = 1e-4;
constexpr double kInlineGlobalTolerance = 1e-5;
constexpr int kRefineRounds = 6;
// Strained points of loose pairs (tie_loose_pairs) that make a round weigh
// residuals up to the reprojection limit: a seam's, not a stray match's.
constexpr int kStrainedForWideLoss = 10;
// Pairs the passes over the registered pairs look at between two looks at
// their `stop`.
constexpr int kPairsPerStopCheck = 64;
// A round that joined more than one point's worth in this many (tracks
// merged or extended) leaves the refinement due for another.
constexpr int64_t kJoinedForAnotherRound = 1000;
// The global refinement's Cauchy scale, in keypoint deviations. The
// keypoints' tail (p90 1 px where the median is 0.06 px, in long tracks)
// is in the keypoints, not the model; at 1.5 deviations it held seed 31's
// walk at 1.95 cm, at 0.5 it ends at 1.27 cm (docs/engine.md, "Half a
// deviation").
constexpr double kRefineLossSigmas = 0.5;

Eigen::Matrix<double, 3, 4> pose_matrix(const SceneImage& image) {
  Eigen::Matrix<double, 3, 4> P;
  P << image.q.toRotationMatrix(), image.t;
  return P;
}

bool has_observation_in(const ScenePoint& point, int image) {
  return std::any_of(
      point.track.begin(), point.track.end(),
      [image](const Observation& obs) { return obs.image == image; });
}

}  // namespace

IncrementalMapper::IncrementalMapper(Scene& scene,
                                     const ReconstructionOptions& options,
                                     StageTimings& timings)
    : scene_(scene), options_(options), timings_(timings) {}

double IncrementalMapper::threshold_normalized(int image) const {
  const SceneCamera& camera = scene_.cameras[scene_.images[image].camera];
  return options_.max_reprojection_px / camera.params[0];
}

std::vector<int> IncrementalMapper::update() {
  std::vector<int> registered;
  if (!scene_.initialized) {
    if (!initialize()) return registered;
    for (size_t i = 0; i < scene_.images.size(); ++i) {
      if (scene_.images[i].registered)
        registered.push_back(static_cast<int>(i));
    }
  }
  register_by_points(registered, options_.max_registrations_per_update, {});
  retire_stalled_components();
  // Photos that no component reaches start one of their own (one a call,
  // so that an increment stays bounded), which may let more register.
  if (start_component(registered))
    register_by_points(registered, options_.max_registrations_per_update, {});
  // Left due by earlier calls that deferred it, when this call registered
  // nothing to run it.
  if (!defer_global_ && scene_.global_ba_deferred && inline_global_due())
    adjust_global();
  return registered;
}

// Registers the image with the most 2D-3D correspondences first; a
// registration adds points, which may let an image that failed succeed.
// Stops after `limit` registrations (0: no limit; the initial model's, in
// `registered` already, do not count), or when `stop` says so, leaving a
// backlog for refine().
void IncrementalMapper::register_by_points(std::vector<int>& registered,
                                           int limit,
                                           const std::function<bool()>& stop) {
  std::set<int> failed;
  const size_t before = registered.size();
  for (;;) {
    if ((limit > 0 &&
         registered.size() - before >= static_cast<size_t>(limit)) ||
        (stop && stop())) {
      scene_.registration_backlog = true;
      return;
    }
    size_t best_count = 0;
    int component = 0;
    const int best = next_image(failed, &best_count, &component);
    if (best < 0) break;
    const bool enough =
        static_cast<int>(best_count) >= options_.min_pose_inliers;
    const bool by_points = enough && register_image(best, component);
    if (by_points) second_opinion(best);
    if (!by_points && !register_from_pair(best, component)) {
      if (!enough) {
        scene_.images[best].reason = "too few matches to the model (" +
                                     std::to_string(best_count) + " 2D-3D)";
      }
      failed.insert(best);
      continue;
    }
    registered.push_back(best);
    failed.clear();
    extend_model(best);
  }
  scene_.registration_backlog = false;
}

// What follows a registration: the image's points, its keypoints moved
// onto their tracks, a loop it may close, the adjustments.
void IncrementalMapper::extend_model(int index) {
  scene_.merge_sweep_due = true;
  triangulate_image(index);
  refine_keypoints(index);
  close_loops(index);
  adjust_local(index);
  geo_register(scene_.images[index].component, scene_.geo_registered);
  merge_through(index);
  if (!inline_global_due()) return;
  if (defer_global_)
    scene_.global_ba_deferred = true;
  else
    adjust_global();
}

// COLMAP's rule for a small model: a global adjustment whenever the model
// grew by `global_ba_growth` since the last one.
bool IncrementalMapper::inline_global_due() const {
  return global_inline() &&
         scene_.registered_count() >=
             options_.global_ba_growth * scene_.registered_at_last_global_ba;
}

// After a loop closure moved the chain onto the old captures, the new
// image's matches to them merge the two sets of tracks; the global
// adjustment then spreads what the closure left.
void IncrementalMapper::close_loops(int index) {
  StageClock clock(timings_.pose_s);
  const LoopClosure loop = close_loop(scene_, index, options_);
  if (!loop.closed) return;
  ++loops_closed_;
  triangulate_image(index);
  scene_.registered_at_last_global_ba = 0;  // refine() is due
  scene_.unsettled_refine_rounds = 0;       // in full, for a changed model
  scene_.refinement_urgent = true;
  if (global_inline()) adjust_global();
}

// Small models adjust globally inside the increment (cheap, and the early
// model needs it); larger ones leave it to refine().
bool IncrementalMapper::global_inline() const {
  return scene_.registered_count() <= options_.inline_global_ba_images;
}

bool IncrementalMapper::refinement_due() const {
  return scene_.initialized &&
         (scene_.registration_backlog ||
          scene_.registered_count() != scene_.registered_at_last_global_ba ||
          (scene_.merge_sweep_due && scene_.component_sizes().size() > 1));
}

bool IncrementalMapper::refinement_urgent() const {
  return scene_.refinement_urgent && refinement_due();
}

// The captures add_capture left waiting at its limit, registered between
// captures; true when that was this call's work: it registered some, or
// `stop` ended it with some left (the adjustment must not start then).
bool IncrementalMapper::catch_up(const std::function<bool()>& stop,
                                 RefineResult& result) {
  if (!scene_.registration_backlog) return false;
  std::vector<int> registered;
  register_by_points(registered, 0, stop);
  for (int index : registered)
    result.registered.push_back(scene_.images[index].id);
  result.ran = !registered.empty();
  result.converged = !scene_.registration_backlog;
  return result.ran || scene_.registration_backlog;
}

RefineResult IncrementalMapper::refine(const std::function<bool()>& stop) {
  RefineResult result;
  if (!refinement_due()) return result;
  const auto start = std::chrono::steady_clock::now();
  result.components_merged = sweep_merges(stop);
  if (result.components_merged > 0) {
    result.ran = result.converged = true;
    result.seconds = seconds_since(start);
    return result;
  }
  if (catch_up(stop, result)) {
    result.seconds = seconds_since(start);
    return result;
  }
  if (!refinement_due()) return result;  // the backlog was all it had
  result.ran = true;
  // Before the adjustment, which then places the new points; pairs left
  // when `stop` ends it are the next round's.
  result.corners_matched = densify_tracks(stop);
  const LooseTies ties = tie_loose_pairs(stop);
  result.loose_links = ties.linked;
  result.strained_links = ties.strained;
  const bool strained = ties.strained >= kStrainedForWideLoss;
  BundleOptions ba = refinement_options(stop, strained);
  const std::vector<Eigen::Vector3d> centres_before = registered_centres();
  const BundleReport report = adjust_bundle(scene_, {}, true, ba);
  result.iterations = report.iterations;
  result.images = report.images;
  result.pixel_sigma = report.pixel_sigma;
  result.loss_scale_px = report.loss_scale_px;
  result.converged = !report.stopped;
  // Stopped before its first iteration: no pose moved, nothing to follow.
  if (report.iterations == 0) {
    result.seconds = seconds_since(start);
    return result;
  }
  std::vector<int> all;
  for (size_t i = 0; i < scene_.images.size(); ++i) {
    if (!scene_.images[i].registered) continue;
    all.push_back(static_cast<int>(i));
    if (!ba.global_images.count(static_cast<int>(i)))
      adjust_pose(static_cast<int>(i));
  }
  filter_points(all);
  // A round that gave way joins at the end of the one that continues it.
  if (!report.stopped) result.tracks_joined = join_tracks(stop);
  // Points this round made or joined may give a photo enough matches to
  // pose it in another component (a walk's two ends meeting): the next
  // call sweeps again. Bounded: the joins die out as the rounds settle.
  if (result.tracks_joined > 0 || result.corners_matched > 0)
    scene_.merge_sweep_due = true;
  result.largest_move = largest_move(centres_before);
  // A round that used up its iterations is continued by the next call, up
  // to kRefineRounds rounds in a row on the same model: a solve that never
  // meets the tolerance must not keep an idle site busy for ever. Rounds
  // counted before a capture registered are not this model's: counting them
  // cut a 400-photo walk's final refinement to one round (docs/engine.md).
  if (scene_.unsettled_at_count != scene_.registered_count()) {
    scene_.unsettled_at_count = scene_.registered_count();
    scene_.unsettled_refine_rounds = 0;
  }
  // Tracks joined by this round give the next one more to pull on.
  const bool joined_many = result.tracks_joined * kJoinedForAnotherRound >
                           static_cast<int64_t>(scene_.points.size());
  const bool settled =
      result.converged && ((report.converged && !joined_many && !strained) ||
                           ++scene_.unsettled_refine_rounds >= kRefineRounds);
  // A merge stays urgent until the refinement settles, not for one round
  // only: seed 53's four-scout walk moved cameras 0.69 m in its first
  // round after the walk and was left at 11 cm when the dense lane took
  // over (bench/RESULTS.md, "Issue 35, twentieth stop").
  if (settled) {
    scene_.registered_at_last_global_ba = scene_.registered_count();
    scene_.unsettled_refine_rounds = 0;
    scene_.refinement_urgent = false;
  }
  result.seconds = seconds_since(start);
  return result;
}

// A refinement round's adjustment: every key view free, placed on the
// fixes first. Under the keypoints' loss a seam's strained links, pixels
// off, would weigh nothing: a `strained` round weighs residuals up to the
// reprojection limit.
BundleOptions IncrementalMapper::refinement_options(
    const std::function<bool()>& stop, bool strained) {
  BundleOptions ba = bundle_options(kGlobalIterations);
  ba.function_tolerance = kRefineTolerance;
  ba.loss_scale_sigmas = strained ? 0 : kRefineLossSigmas;
  if (strained) ba.loss_scale_px = options_.max_reprojection_px;
  ba.stop = stop;
  ba.max_track_observations = kGlobalTrack;
  const std::vector<int> keys = key_views();
  ba.global_images.insert(keys.begin(), keys.end());
  align_to_priors(ba);
  return ba;
}

// Verified matches whose keypoints the model still holds as two points,
// or one as none, joined where one position explains both (merge_tracks,
// extend_track), as COLMAP completes and merges tracks after a global
// adjustment. A merge or a round that moved one stretch onto another
// leaves both sides' points of one place apart, each held by its own side
// only; joined, they tie the sides together in the next round. Returns
// the matches joined; stops early when `stop` says so.
int IncrementalMapper::join_tracks(const std::function<bool()>& stop) {
  StageClock clock(timings_.triangulation_s);
  int joined = 0;
  visit_linked_pairs(
      stop, [&](const std::pair<int, int>& key, const ImagePair& pair) {
        const SceneImage& a = scene_.images[key.first];
        const SceneImage& b = scene_.images[key.second];
        for (const auto& [first, second] : pair.matches) {
          // One point already, or neither triangulated (not this pass's work).
          if (a.point_of[first] == b.point_of[second]) continue;
          joined += link_match({key.first, first}, {key.second, second},
                               options_.max_reprojection_px);
        }
      });
  return joined;
}

void IncrementalMapper::visit_linked_pairs(
    const std::function<bool()>& stop,
    const std::function<void(const std::pair<int, int>&, const ImagePair&)>&
        visit) {
  int checked_pairs = 0;
  for (const auto& [key, pair] : scene_.pairs) {
    if (stop && ++checked_pairs % kPairsPerStopCheck == 0 && stop()) return;
    const SceneImage& a = scene_.images[key.first];
    const SceneImage& b = scene_.images[key.second];
    if (a.registered && b.registered && a.component == b.component)
      visit(key, pair);
  }
}

std::vector<Eigen::Vector3d> IncrementalMapper::registered_centres() const {
  std::vector<Eigen::Vector3d> centres;
  for (const SceneImage& image : scene_.images)
    if (image.registered) centres.push_back(image.centre());
  return centres;
}

double IncrementalMapper::largest_move(
    const std::vector<Eigen::Vector3d>& before) const {
  const std::vector<Eigen::Vector3d> after = registered_centres();
  double largest = 0;
  for (size_t i = 0; i < std::min(before.size(), after.size()); ++i)
    largest = std::max(largest, (after[i] - before[i]).norm());
  return largest;
}

// The unregistered image with the most 2D-3D correspondences to one
// component (-1 if none has any), skipping `failed`, and that component;
// only `only`'s when it is >= 0.
int IncrementalMapper::next_image(const std::set<int>& failed, size_t* count,
                                  int* component, int only) const {
  int best = -1;
  *count = 0;
  for (size_t i = 0; i < scene_.images.size(); ++i) {
    const SceneImage& image = scene_.images[i];
    if (image.removed || image.registered || failed.count(static_cast<int>(i)))
      continue;
    for (const auto& [c, corr] :
         correspondences_by_component(static_cast<int>(i))) {
      if ((only >= 0 && c != only) || corr.size() <= *count) continue;
      best = static_cast<int>(i);
      *count = corr.size();
      *component = c;
    }
  }
  return best;
}

std::map<int, std::vector<std::pair<int, int64_t>>>
IncrementalMapper::correspondences_by_component(int image) const {
  std::map<int, std::vector<std::pair<int, int64_t>>> result;
  std::map<int, std::set<int>> seen;
  for (const auto& [other, pair] : scene_.pairs_of(image)) {
    const SceneImage& o = scene_.images[other];
    if (!o.registered) continue;
    auto& out = result[o.component];
    std::set<int>& taken = seen[o.component];
    for (const auto& [mine, theirs] : oriented_matches(image, other, *pair)) {
      const int64_t point = o.point_of[theirs];
      if (point < 0 || !taken.insert(mine).second) continue;
      out.emplace_back(mine, point);
    }
  }
  return result;
}

std::vector<std::pair<int, int64_t>> IncrementalMapper::correspondences(
    int image, int component) const {
  auto all = correspondences_by_component(image);
  auto it = all.find(component);
  if (it == all.end()) return {};
  return std::move(it->second);
}

bool IncrementalMapper::initialize() {
  int usable = 0;
  for (const SceneImage& image : scene_.images) usable += image.removed ? 0 : 1;
  if (usable < 3) return false;
  const auto ranked = initial_pairs([](int, int) { return true; });
  const size_t attempts = std::min<size_t>(ranked.size(), 3);
  for (size_t i = 0; i < attempts; ++i) {
    const auto [a, b] = ranked[i];
    if (try_initial_pair(a, b, scene_.pairs.at({a, b}))) return true;
  }
  for (SceneImage& image : scene_.images) {
    if (!image.removed)
      image.reason = "waiting for a well-conditioned initial pair";
  }
  return false;
}

// Best-conditioned pairs first: many inliers with enough parallax, and
// not explained by a homography (a plane or a pure rotation). Parallax
// below 4 degrees discounts a pair in proportion; below 1 it is skipped.
std::vector<std::pair<int, int>> IncrementalMapper::initial_pairs(
    const std::function<bool(int, int)>& usable) const {
  std::vector<std::pair<double, std::pair<int, int>>> ranked;
  for (const auto& [key, pair] : scene_.pairs) {
    if (pair.median_angle_deg < 1.0 || pair.homography_ratio > 0.95) continue;
    if (!usable(key.first, key.second)) continue;
    const double parallax = std::min(1.0, pair.median_angle_deg / 4.0);
    ranked.push_back({pair.matches.size() * parallax, key});
  }
  std::sort(ranked.begin(), ranked.end(), [](const auto& x, const auto& y) {
    return x.first != y.first ? x.first > y.first : x.second < y.second;
  });
  std::vector<std::pair<int, int>> result;
  for (const auto& entry : ranked) result.push_back(entry.second);
  return result;
}

// Puts a pair's two photos in `component` at their relative pose (the
// first at the origin, a baseline of unit length) and triangulates its
// matches; returns the points made.
size_t IncrementalMapper::place_pair(int a, int b, const ImagePair& pair,
                                     int component) {
  SceneImage& first = scene_.images[a];
  SceneImage& second = scene_.images[b];
  first.q.setIdentity();
  first.t.setZero();
  second.q = Eigen::Quaterniond(pair.R).normalized();
  second.t = pair.t;
  for (SceneImage* image : {&first, &second}) {
    image->registered = true;
    image->component = component;
  }
  StageClock clock(timings_.triangulation_s);
  const size_t before = scene_.points.size();
  for (const auto& [ka, kb] : pair.matches)
    triangulate_pair_match({a, ka}, {b, kb}, options_.max_reprojection_px);
  return scene_.points.size() - before;
}

bool IncrementalMapper::try_initial_pair(int a, int b, const ImagePair& pair) {
  reset_model();
  scene_.reference_image = a;
  scene_.scale_image = b;
  if (place_pair(a, b, pair, 0) < 50) {
    reset_model();
    return false;
  }
  refine_keypoints(b);
  adjust_global();
  // The model exists once a third image registers against it.
  scene_.initialized = true;
  const int third = register_third(0);
  if (third < 0) {
    reset_model();
    return false;
  }
  refine_keypoints(third);
  adjust_global();
  geo_register(0, false);
  return true;
}

bool IncrementalMapper::register_image(int index, int component) {
  StageClock clock(timings_.pose_s);
  SceneImage& image = scene_.images[index];
  const SceneCamera& camera = scene_.cameras[image.camera];
  const auto corr = correspondences(index, component);
  std::vector<Eigen::Vector3d> world;
  std::vector<Eigen::Vector2d> points;
  for (const auto& [keypoint, point] : corr) {
    world.push_back(scene_.points.at(point).xyz);
    points.push_back(normalize(camera, image.keypoints[keypoint]));
  }
  const auto pose = estimate_absolute_pose(
      world, points, threshold_normalized(index), options_.min_pose_inliers);
  if (!pose) {
    image.reason = "absolute pose failed (" + std::to_string(corr.size()) +
                   " 2D-3D correspondences, too few agree)";
    return false;
  }
  image.q = pose->q;
  image.t = pose->t;
  image.registered = true;
  image.component = component;
  image.status = CaptureStatus::kRegistered;
  image.reason.clear();
  image.pose_inliers = static_cast<int>(pose->inliers.size());
  for (int i : pose->inliers) {
    const auto& [keypoint, point] = corr[i];
    if (image.point_of[keypoint] < 0 &&
        !has_observation_in(scene_.points.at(point), index)) {
      scene_.add_observation(point, {index, keypoint});
    }
  }
  return true;
}

// Correspondences that agree can still leave a pose loose: points on one
// small patch (a pillar passing close by) let a rotation trade against a
// translation, and every later photo registered to the points this one
// triangulates inherits the error (seed 31's block walk turned on, 10
// degrees a photo, for 40 photos after two such poses; docs/engine.md,
// "Loose poses"). Loose: at 1 px of keypoint noise, the rotation is
// uncertain by more than the inlier threshold's angle.
bool IncrementalMapper::pose_loose(int index) const {
  const SceneImage& image = scene_.images[index];
  const double focal = scene_.cameras[image.camera].params[0];
  std::vector<Eigen::Vector3d> inliers;
  for (const int64_t point : image.point_of)
    if (point >= 0) inliers.push_back(scene_.points.at(point).xyz);
  const PoseUncertainty u =
      pose_uncertainty(image.q, image.t, inliers, 1 / focal);
  return u.rotation_sigma_rad * focal > options_.max_reprojection_px;
}

// Few agreeing matches of many mean no hypothesis holds: a pose from a pair
// must explain at least 3 and a third of the 2D-3D matches.
bool IncrementalMapper::pair_pose_holds(const PairPose& pose,
                                        size_t correspondences) {
  return pose.agreeing.size() >= 3 &&
         3 * pose.agreeing.size() >= correspondences;
}

// When too few 2D-3D matches agree on an absolute pose (a wide step along a
// chain of photos shares few points with the model), the relative pose to
// the registered neighbour it matches best gives the orientation and the
// direction of the baseline; the 2D-3D matches it has then only need to
// agree on the baseline's length.
bool IncrementalMapper::register_from_pair(int index, int component) {
  StageClock clock(timings_.pose_s);
  const auto corr = correspondences(index, component);
  const auto pose = pair_pose(index, corr, component);
  if (!pose || !pair_pose_holds(*pose, corr.size())) return false;
  set_pose(index, pose->q, pose->centre, pose->agreeing, component);
  return true;
}

// A registration on few P3P inliers may be a wrong solution that a turn on
// the spot or a step from a neighbour explains better: the pose that
// explains more of the 2D-3D matches stays. A loose P3P pose gives way to
// the relative pose to the best-matched neighbour (whose rotation many
// 2D-2D matches fix) whenever that one holds as register_from_pair asks.
void IncrementalMapper::second_opinion(int index) {
  SceneImage& image = scene_.images[index];
  const bool loose = pose_loose(index);
  if (!loose && image.pose_inliers >= kConfidentInliers) return;
  StageClock clock(timings_.pose_s);
  const int component = image.component;
  const auto corr = correspondences(index, component);
  const auto pose = pair_pose(index, corr, component);
  if (!pose) return;
  const bool better =
      loose ? pair_pose_holds(*pose, corr.size())
            : static_cast<int>(pose->agreeing.size()) > image.pose_inliers;
  if (!better) return;
  for (size_t k = 0; k < image.point_of.size(); ++k) {
    const int64_t point = image.point_of[k];
    if (point < 0) continue;
    std::erase(scene_.points.at(point).track,
               Observation{index, static_cast<int>(k)});
    image.point_of[k] = -1;
  }
  set_pose(index, pose->q, pose->centre, pose->agreeing, component);
}

void IncrementalMapper::set_pose(
    int index, const Eigen::Quaterniond& q, const Eigen::Vector3d& centre,
    const std::vector<std::pair<int, int64_t>>& agreeing, int component) {
  SceneImage& image = scene_.images[index];
  image.q = q;
  image.t = -(q * centre);
  image.registered = true;
  image.component = component;
  image.status = CaptureStatus::kRegistered;
  image.reason.clear();
  image.pose_inliers = static_cast<int>(agreeing.size());
  for (const auto& [keypoint, point] : agreeing) {
    if (image.point_of[keypoint] < 0 &&
        !has_observation_in(scene_.points.at(point), index)) {
      scene_.add_observation(point, {index, keypoint});
    }
  }
}

// The best pose the relative pose to the best-matched registered
// neighbour of `component` offers, and the 2D-3D matches it explains.
std::optional<IncrementalMapper::PairPose> IncrementalMapper::pair_pose(
    int index, const std::vector<std::pair<int, int64_t>>& corr,
    int component) const {
  int other = -1;
  const ImagePair* best = nullptr;
  for (const auto& [candidate, pair] : scene_.pairs_of(index)) {
    const SceneImage& partner = scene_.images[candidate];
    if (!partner.registered || partner.component != component) continue;
    if (!best || pair->matches.size() > best->matches.size()) {
      best = pair;
      other = candidate;
    }
  }
  if (!best) return std::nullopt;
  const SceneImage& anchor = scene_.images[other];
  const Eigen::Matrix3d R_anchor = anchor.q.toRotationMatrix();
  Eigen::Matrix3d R;
  Eigen::Vector3d direction;  // of this camera's centre from the anchor's
  if (index > other) {        // stored as x_index = R x_other + t
    R = best->R * R_anchor;
    direction = R_anchor.transpose() * (-best->R.transpose() * best->t);
  } else {  // x_other = R x_index + t
    R = best->R.transpose() * R_anchor;
    direction = R_anchor.transpose() * best->t;
  }
  direction.normalize();
  const Eigen::Vector3d C0 = anchor.centre();
  const Eigen::Quaterniond q = Eigen::Quaterniond(R).normalized();
  // Hypotheses: a turn on the spot (a burst; the essential matrix's
  // baseline and even its rotation are then unreliable, so the turn is
  // fitted to the rays themselves), or a step along the baseline.
  std::vector<std::pair<Eigen::Quaterniond, Eigen::Vector3d>> poses;
  if (auto turn = turn_rotation(index, other, *best))
    poses.push_back({Eigen::Quaterniond(*turn * R_anchor).normalized(), C0});
  poses.push_back({q, C0});
  if (auto length = baseline_length(index, R, C0, direction, corr))
    poses.push_back({q, C0 + *length * direction});
  PairPose result{q, C0, {}};
  for (const auto& [pose_q, pose_c] : poses) {
    auto explained = agreeing_matches(index, pose_q, pose_c, corr);
    if (explained.size() > result.agreeing.size())
      result = {pose_q, pose_c, std::move(explained)};
  }
  return result;
}

// The distance along `direction` from C0 that the median 2D-3D match
// puts the camera at (R its world-to-camera rotation); none when fewer than
// 3 matches fix it.
std::optional<double> IncrementalMapper::baseline_length(
    int index, const Eigen::Matrix3d& R, const Eigen::Vector3d& C0,
    const Eigen::Vector3d& direction,
    const std::vector<std::pair<int, int64_t>>& corr) const {
  const SceneImage& image = scene_.images[index];
  const SceneCamera& camera = scene_.cameras[image.camera];
  std::vector<double> lengths;
  for (const auto& [keypoint, point] : corr) {
    const Eigen::Vector2d x = normalize(camera, image.keypoints[keypoint]);
    const Eigen::Vector3d ray(x.x(), x.y(), 1.0);
    const Eigen::Vector3d a = ray.cross(R * (scene_.points.at(point).xyz - C0));
    const Eigen::Vector3d b = ray.cross(R * direction);
    if (b.squaredNorm() < 1e-12) continue;
    const double length = a.dot(b) / b.squaredNorm();
    if (length > 0) lengths.push_back(length);
  }
  if (lengths.size() < 3) return std::nullopt;
  std::nth_element(lengths.begin(), lengths.begin() + lengths.size() / 2,
                   lengths.end());
  return lengths[lengths.size() / 2];
}

// The rotation (camera to camera) that explains most of a pair's matches
// as a turn on the spot; none when most of them need a baseline.
std::optional<Eigen::Matrix3d> IncrementalMapper::turn_rotation(
    int index, int other, const ImagePair& pair) const {
  const SceneImage& image = scene_.images[index];
  const SceneImage& anchor = scene_.images[other];
  const SceneCamera& camera = scene_.cameras[image.camera];
  const SceneCamera& anchor_camera = scene_.cameras[anchor.camera];
  std::vector<Eigen::Vector3d> from, to;
  for (const auto& [mine, theirs] : oriented_matches(index, other, pair)) {
    from.push_back(normalize(anchor_camera, anchor.keypoints[theirs])
                       .homogeneous()
                       .normalized());
    to.push_back(
        normalize(camera, image.keypoints[mine]).homogeneous().normalized());
  }
  const int most = static_cast<int>(from.size() * 7 / 10);
  return estimate_rotation(from, to, threshold_normalized(index),
                           std::max(options_.min_pose_inliers, most),
                           static_cast<uint64_t>(index), nullptr);
}

// The 2D-3D matches that a camera at `centre` turned by `q` explains.
std::vector<std::pair<int, int64_t>> IncrementalMapper::agreeing_matches(
    int index, const Eigen::Quaterniond& q, const Eigen::Vector3d& centre,
    const std::vector<std::pair<int, int64_t>>& corr) const {
  const SceneImage& image = scene_.images[index];
  const SceneCamera& camera = scene_.cameras[image.camera];
  SceneImage trial;
  trial.q = q;
  trial.t = -(q * centre);
  std::vector<std::pair<int, int64_t>> agreeing;
  for (const auto& [keypoint, point] : corr) {
    Eigen::Vector2d projected;
    if (project(camera, trial, scene_.points.at(point).xyz, &projected) &&
        (projected - image.keypoints[keypoint]).norm() <=
            options_.max_reprojection_px) {
      agreeing.emplace_back(keypoint, point);
    }
  }
  return agreeing;
}

// Two points that a match says are one: merged where one position explains
// every observation of both, which links the chain of photos into longer
// tracks (and closes loops).
void IncrementalMapper::merge_tracks(int64_t a, int64_t b) {
  merge_tracks(a, b, options_.max_reprojection_px);
}

void IncrementalMapper::merge_tracks(int64_t a, int64_t b, double max_px) {
  if (a == b) return;
  const ScenePoint& pa = scene_.points.at(a);
  const ScenePoint& pb = scene_.points.at(b);
  for (const Observation& obs : pb.track) {
    if (has_observation_in(pa, obs.image)) return;
  }
  const double na = static_cast<double>(pa.track.size());
  const double nb = static_cast<double>(pb.track.size());
  const Eigen::Vector3d merged = (pa.xyz * na + pb.xyz * nb) / (na + nb);
  for (const ScenePoint* point : {&pa, &pb}) {
    for (const Observation& obs : point->track) {
      const SceneImage& image = scene_.images[obs.image];
      Eigen::Vector2d projected;
      if (!project(scene_.cameras[image.camera], image, merged, &projected) ||
          (projected - image.keypoints[obs.keypoint]).norm() > max_px) {
        return;
      }
    }
  }
  if (na >= nb) {
    scene_.merge_points(a, b, merged);
  } else {
    scene_.merge_points(b, a, merged);
  }
}

void IncrementalMapper::extend_track(int64_t point_id, Observation obs) {
  extend_track(point_id, obs, options_.max_reprojection_px);
}

void IncrementalMapper::extend_track(int64_t point_id, Observation obs,
                                     double max_px) {
  ScenePoint& point = scene_.points.at(point_id);
  if (has_observation_in(point, obs.image)) return;
  const SceneImage& image = scene_.images[obs.image];
  Eigen::Vector2d projected;
  if (!project(scene_.cameras[image.camera], image, point.xyz, &projected))
    return;
  if ((projected - image.keypoints[obs.keypoint]).norm() > max_px) return;
  scene_.add_observation(point_id, obs);
}

bool IncrementalMapper::triangulate_pair_match(Observation first,
                                               Observation second,
                                               double max_px) {
  const auto X = triangulated(scene_.images[first.image], first,
                              scene_.images[second.image], second, max_px);
  if (!X) return false;
  scene_.add_point(*X, {first, second});
  return true;
}

std::optional<Eigen::Vector3d> IncrementalMapper::triangulated(
    const SceneImage& a, Observation first, const SceneImage& b,
    Observation second) const {
  return triangulated(a, first, b, second, options_.max_reprojection_px);
}

// The point two observations see, with `a` and `b` giving their images'
// poses (an image's own, or a pose it would have elsewhere); none unless
// it has the parallax and both reprojections a new point needs.
std::optional<Eigen::Vector3d> IncrementalMapper::triangulated(
    const SceneImage& a, Observation first, const SceneImage& b,
    Observation second, double max_px) const {
  const SceneImage& image_a = scene_.images[first.image];
  const SceneImage& image_b = scene_.images[second.image];
  const SceneCamera& ca = scene_.cameras[image_a.camera];
  const SceneCamera& cb = scene_.cameras[image_b.camera];
  const Eigen::Vector2d& ka = image_a.keypoints[first.keypoint];
  const Eigen::Vector2d& kb = image_b.keypoints[second.keypoint];
  const auto X = triangulate({pose_matrix(a), pose_matrix(b)},
                             {normalize(ca, ka), normalize(cb, kb)});
  if (!X || !X->allFinite()) return std::nullopt;
  // Written to fail on NaN too: two cameras at one place (a turn on the
  // spot) give a point with no defined angle.
  if (!(triangulation_angle_deg(a.centre(), b.centre(), *X) >=
        options_.min_triangulation_angle_deg)) {
    return std::nullopt;
  }
  Eigen::Vector2d pa, pb;
  if (!project(ca, a, *X, &pa) || !project(cb, b, *X, &pb)) return std::nullopt;
  if ((pa - ka).norm() > max_px || (pb - kb).norm() > max_px)
    return std::nullopt;
  return X;
}

void IncrementalMapper::triangulate_image(int index) {
  StageClock clock(timings_.triangulation_s);
  const int component = scene_.images[index].component;
  for (const auto& [other, pair] : scene_.pairs_of(index)) {
    const SceneImage& partner = scene_.images[other];
    if (!partner.registered || partner.component != component) continue;
    for (const auto& [mine, theirs] : oriented_matches(index, other, *pair))
      link_match({index, mine}, {other, theirs});
  }
}

// One verified match into the tracks: two points merged, a track extended,
// or a new point, wherever one position explains both keypoints.
void IncrementalMapper::link_match(Observation first, Observation second) {
  link_match(first, second, options_.max_reprojection_px);
}

bool IncrementalMapper::link_match(Observation first, Observation second,
                                   double max_px) {
  const int64_t p_first = scene_.images[first.image].point_of[first.keypoint];
  const int64_t p_second =
      scene_.images[second.image].point_of[second.keypoint];
  if (p_first >= 0 && p_second >= 0) {
    merge_tracks(p_first, p_second, max_px);
  } else if (p_second >= 0) {
    extend_track(p_second, first, max_px);
  } else if (p_first >= 0) {
    extend_track(p_first, second, max_px);
  } else {
    triangulate_pair_match(first, second, max_px);
  }
  const int64_t linked = scene_.images[first.image].point_of[first.keypoint];
  return linked >= 0 &&
         linked == scene_.images[second.image].point_of[second.keypoint];
}

// Once registered and triangulated, a new image's keypoints move onto the
// spot their track's reference shows (keypoint_refinement.h), before any
// adjustment sees them. Each image is refined once: its patches are those
// of the detected keypoints.
void IncrementalMapper::refine_keypoints(int index) {
  StageClock clock(timings_.triangulation_s);
  SceneImage& image = scene_.images[index];
  if (image.patches.rows != static_cast<int>(image.keypoints.size()) ||
      !image.refined_keypoints.empty())
    return;
  for (size_t k = 0; k < image.keypoints.size(); ++k) {
    if (image.point_of[k] < 0) continue;
    const auto reference = track_reference(image.point_of[k], index);
    if (!reference) continue;
    const Observation target{index, static_cast<int>(k)};
    auto shift = align_patch(patch_of(*reference), patch_of(target));
    if (!shift)
      shift = align_through_neighbour(image.point_of[k], *reference, target);
    if (!shift) continue;
    image.keypoints[k] += *shift;
    image.refined_keypoints.emplace_back(static_cast<int>(k),
                                         image.keypoints[k]);
  }
}

const uchar* IncrementalMapper::patch_of(const Observation& obs) const {
  return scene_.images[obs.image].patches.ptr<uchar>(obs.keypoint);
}

// A keypoint seen too differently from its track's reference for their
// patches to align (most often far along a long track) aligns instead to
// the track's observations seen most like it, through that observation's
// own alignment to the reference: the reference's spot lies at that shift
// on its patch. One step only, so no error adds up along a chain.
std::optional<Eigen::Vector2d> IncrementalMapper::align_through_neighbour(
    int64_t point, const Observation& reference,
    const Observation& target) const {
  constexpr size_t kNeighboursTried = 2;
  const Eigen::Vector3d& xyz = scene_.points.at(point).xyz;
  const auto ray = [&](int image) {
    return (scene_.images[image].centre() - xyz).normalized();
  };
  const Eigen::Vector3d target_ray = ray(target.image);
  std::vector<std::pair<double, Observation>> neighbours;
  for (const Observation& obs : scene_.points.at(point).track) {
    const SceneImage& image = scene_.images[obs.image];
    if (obs.image == target.image || obs.image == reference.image ||
        !image.registered || image.patches.empty())
      continue;
    neighbours.emplace_back(-ray(obs.image).dot(target_ray), obs);
  }
  const size_t tried = std::min(kNeighboursTried, neighbours.size());
  std::partial_sort(
      neighbours.begin(), neighbours.begin() + tried, neighbours.end(),
      [](const auto& a, const auto& b) { return a.first < b.first; });
  for (size_t i = 0; i < tried; ++i) {
    const Observation& neighbour = neighbours[i].second;
    // Aligned again rather than read from its refined position: that
    // position is its shift onto the reference the track had then, which
    // a merge of tracks may since have changed.
    const auto onto_reference =
        align_patch(patch_of(reference), patch_of(neighbour));
    if (!onto_reference) continue;
    if (auto shift =
            align_patch(patch_of(neighbour), patch_of(target), *onto_reference))
      return shift;
  }
  return std::nullopt;
}

// The observation of `point` the others align to: the one in the earliest
// added image with patches, other than `image` itself.
std::optional<Observation> IncrementalMapper::track_reference(int64_t point,
                                                              int image) const {
  std::optional<Observation> reference;
  for (const Observation& obs : scene_.points.at(point).track) {
    if (obs.image == image || scene_.images[obs.image].patches.empty())
      continue;
    if (!reference || obs.image < reference->image) reference = obs;
  }
  return reference;
}

std::vector<int> IncrementalMapper::covisible_images(int index,
                                                     int limit) const {
  std::map<int, int> shared;
  const SceneImage& image = scene_.images[index];
  for (int64_t point : image.point_of) {
    if (point < 0) continue;
    for (const Observation& obs : scene_.points.at(point).track) {
      if (obs.image != index) ++shared[obs.image];
    }
  }
  std::vector<std::pair<int, int>> ranked;
  for (const auto& [other, count] : shared) ranked.push_back({count, other});
  std::sort(ranked.begin(), ranked.end(), [](const auto& x, const auto& y) {
    return x.first != y.first ? x.first > y.first : x.second < y.second;
  });
  std::vector<int> result;
  for (size_t i = 0; i < ranked.size() && static_cast<int>(i) < limit; ++i) {
    result.push_back(ranked[i].second);
  }
  return result;
}

// A registered image with almost no baseline to a covisible one (a photo
// of a burst, a scout standing still): it adds observations but no
// parallax, so adjusting the map around it would buy nothing.
bool IncrementalMapper::near_duplicate_view(
    int index, const std::vector<int>& covisible) const {
  const SceneImage& image = scene_.images[index];
  std::vector<double> depths;
  for (int64_t point : image.point_of) {
    if (point >= 0)
      depths.push_back((image.q * scene_.points.at(point).xyz + image.t).z());
  }
  if (depths.size() < 20) return false;
  std::nth_element(depths.begin(), depths.begin() + depths.size() / 2,
                   depths.end());
  const double depth = depths[depths.size() / 2];
  for (int other : covisible) {
    const SceneImage& view = scene_.images[other];
    if ((view.centre() - image.centre()).norm() < kKeyViewBaseline * depth &&
        view.q.angularDistance(image.q) < kKeyViewAngleRad)
      return true;
  }
  return false;
}

// The views that carry the model's geometry: in order of addition, each
// registered image that is not a near duplicate of an earlier key view
// (plus the gauge images). The others follow them by their own pose.
std::vector<int> IncrementalMapper::key_views() const {
  std::vector<int> keys;
  for (size_t i = 0; i < scene_.images.size(); ++i) {
    const int index = static_cast<int>(i);
    if (!scene_.images[i].registered) continue;
    const bool gauge =
        index == scene_.reference_image || index == scene_.scale_image;
    if (gauge || !near_duplicate_view(index, keys)) keys.push_back(index);
  }
  return keys;
}

// Motion-only adjustment of one registered image against fixed points.
void IncrementalMapper::adjust_pose(int index) {
  BundleOptions ba = bundle_options(10);
  ba.points_fixed = true;
  adjust_bundle(scene_, {index}, false, ba);
}

void IncrementalMapper::adjust_local(int index) {
  StageClock clock(timings_.bundle_adjustment_s);
  std::vector<int> free = covisible_images(index, options_.local_ba_images - 1);
  if (near_duplicate_view(index, free)) {
    adjust_pose(index);
    filter_points({index});
    return;
  }
  free.push_back(index);
  BundleOptions ba = bundle_options(15);
  ba.function_tolerance = kLocalTolerance;
  ba.max_fixed_images = options_.local_ba_fixed;
  ba.max_track_observations = options_.local_ba_track;
  ba.strong_keypoints = options_.match_features;
  // Aligning to the priors moves every camera: cheap, but O(model), so only
  // while the model is small; later the global refinement keeps it aligned.
  if (global_inline()) align_to_priors(ba);
  adjust_bundle(scene_, free, false, ba);
  filter_points(free);
}

void IncrementalMapper::adjust_global() {
  StageClock clock(timings_.bundle_adjustment_s);
  ++global_adjustments_;
  BundleOptions ba = bundle_options(kGlobalIterations);
  ba.function_tolerance = kInlineGlobalTolerance;
  align_to_priors(ba);
  adjust_bundle(scene_, {}, true, ba);
  std::vector<int> all;
  for (size_t i = 0; i < scene_.images.size(); ++i) {
    if (scene_.images[i].registered) all.push_back(static_cast<int>(i));
  }
  const size_t before = scene_.points.size();
  filter_points(all);
  // Outliers pull a robust adjustment less than a plain one, but they still
  // pull: adjust once more when the filter removed a noticeable share.
  if (scene_.points.size() + before / 50 < before)
    adjust_bundle(scene_, {}, true, ba);
  scene_.registered_at_last_global_ba = scene_.registered_count();
  scene_.refinement_urgent = false;  // the whole model adjusted
  scene_.global_ba_deferred = false;
}

// Drops observations that reproject badly, then points left with fewer than
// two observations or with too little parallax to be trusted.
void IncrementalMapper::filter_points(const std::vector<int>& images) {
  std::set<int64_t> touched;
  for (int index : images) {
    for (int64_t point : scene_.images[index].point_of) {
      if (point >= 0) touched.insert(point);
    }
  }
  for (int64_t id : touched) {
    ScenePoint& point = scene_.points.at(id);
    std::vector<Observation> kept;
    for (const Observation& obs : point.track) {
      SceneImage& image = scene_.images[obs.image];
      Eigen::Vector2d projected;
      const bool good =
          project(scene_.cameras[image.camera], image, point.xyz, &projected) &&
          (projected - image.keypoints[obs.keypoint]).norm() <=
              options_.max_reprojection_px;
      if (good) {
        kept.push_back(obs);
      } else {
        image.point_of[obs.keypoint] = -1;
      }
    }
    point.track = std::move(kept);
    double best_angle = 0;
    for (size_t i = 0; i < point.track.size(); ++i) {
      for (size_t j = i + 1; j < point.track.size(); ++j) {
        best_angle = std::max(
            best_angle,
            triangulation_angle_deg(
                scene_.images[point.track[i].image].centre(),
                scene_.images[point.track[j].image].centre(), point.xyz));
      }
    }
    if (point.track.size() < 2 || !point.xyz.allFinite() ||
        !(best_angle >= options_.min_triangulation_angle_deg / 3)) {
      scene_.remove_point(id);
    }
  }
}

// The model's up direction from its cameras: level cameras have horizontal
// x axes, so up is the direction most nearly perpendicular to all of them;
// the mean of the cameras' up axes (-y) breaks the tie when the x axes are
// nearly parallel (cameras all facing one way). Over one component.
Eigen::Vector3d IncrementalMapper::model_up(int component) const {
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  Eigen::Vector3d mean_up = Eigen::Vector3d::Zero();
  int count = 0;
  for (const SceneImage& image : scene_.images) {
    if (!image.registered || image.component != component) continue;
    const Eigen::Matrix3d R = image.q.toRotationMatrix();
    const Eigen::Vector3d x_axis = R.row(0).transpose();
    scatter += x_axis * x_axis.transpose();
    mean_up -= R.row(1).transpose();
    ++count;
  }
  mean_up.normalize();
  scatter += 0.05 * count *
             (Eigen::Matrix3d::Identity() - mean_up * mean_up.transpose());
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(scatter);
  Eigen::Vector3d up = eigen.eigenvectors().col(0);  // smallest eigenvalue
  return up.dot(mean_up) < 0 ? -up : up;
}

// Turns a similarity about the fixes' centroid so the model's up maps to
// ENU up: the GPS heights are too noisy to fix the tilt.
void IncrementalMapper::level(Similarity& sim,
                              const std::vector<Eigen::Vector3d>& fixes,
                              const std::vector<int>& inliers,
                              int component) const {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (int i : inliers) centroid += fixes[i];
  centroid /= std::max<size_t>(1, inliers.size());
  const Eigen::Matrix3d fix =
      Eigen::Quaterniond::FromTwoVectors(sim.R * model_up(component),
                                         Eigen::Vector3d::UnitZ())
          .toRotationMatrix();
  sim.R = fix * sim.R;
  sim.t = fix * (sim.t - centroid) + centroid;
}

// Moves a component into the site's ENU frame whenever its cameras and
// their fixes disagree by more than the adjustment itself would fix.
// `placed`: the component is in ENU already. The first time (and whenever
// the priors' fit below is out of reach), a robust similarity from camera
// centres to GPS positions, levelled by the cameras, places it. Once
// placed, the test is the adjustment's own fit to the priors
// (align_to_priors): the levelling by the cameras' mean up axis tilts a
// model by its cameras' mean pitch where the upright prior does not, and the
// two fits disagreed by about 5 degrees at every photo of an early walk,
// each time at the price of a global adjustment (docs/engine.md). True when
// it is in ENU afterwards.
bool IncrementalMapper::geo_register(int component, bool placed) {
  if (!scene_.enu_origin) return placed;
  std::optional<Similarity> sim;
  const std::optional<Similarity> start = first_placement(component);
  if (placed) sim = fit_to_priors(bundle_options(0), component, start);
  // A fit the priors cannot follow (it would halve or double the scale: a
  // first placement by three noisy fixes can be that far off) places the
  // component again from scratch.
  if (!sim) sim = start;
  if (!sim) return placed;
  const double angle = Eigen::AngleAxisd(sim->R).angle() * 180 / M_PI;
  const bool far = !placed || angle > 2 ||
                   std::abs(std::log(sim->scale)) > 0.02 || sim->t.norm() > 1.0;
  if (!far) return true;
  transform_model(*sim, component);
  scene_.geo_registered = true;
  if (global_inline()) {
    adjust_global();
  } else {
    scene_.registered_at_last_global_ba = 0;  // refine() is due
  }
  return true;
}

// The robust similarity from a component's camera centres to their fixes,
// levelled by the cameras (the GPS heights are too noisy to fix the tilt).
std::optional<Similarity> IncrementalMapper::first_placement(
    int component) const {
  const FixedCentres fixed = fixed_centres(scene_, component);
  std::vector<int> inliers;
  auto sim = robust_placement(fixed, scene_.images.size(), &inliers);
  if (sim && options_.upright_sigma_deg > 0)
    level(*sim, fixed.fixes, inliers, component);
  return sim;
}

void IncrementalMapper::transform_model(const Similarity& sim, int component) {
  for (auto& [id, point] : scene_.points) {
    if (scene_.component_of_point(id) == component)
      point.xyz = sim.apply(point.xyz);
  }
  const Eigen::Quaterniond rotation(sim.R);
  for (SceneImage& image : scene_.images) {
    if (!image.registered || image.component != component) continue;
    const Eigen::Vector3d centre = sim.apply(image.centre());
    image.q = (image.q * rotation.conjugate()).normalized();
    image.t = -(image.q * centre);
  }
}

BundleOptions IncrementalMapper::bundle_options(int max_iterations) const {
  BundleOptions ba;
  ba.gps_priors = scene_.geo_registered;
  ba.upright_sigma_deg = options_.upright_sigma_deg;
  ba.pixel_sigma = 0;  // the features' own deviation against the fixes
  ba.max_iterations = max_iterations;
  ba.threads = options_.deterministic ? 1 : options_.threads;
  return ba;
}

// Reprojection errors leave the model's position, orientation and scale to
// the priors alone, and a joint adjustment creeps along such weak
// directions; solving them first lets it converge in a few iterations.
void IncrementalMapper::align_to_priors(const BundleOptions& ba) {
  if (!scene_.geo_registered) return;
  for (const auto& [component, size] : scene_.component_sizes()) {
    if (auto sim = fit_to_priors(ba, component, first_placement(component))) {
      transform_model(*sim, component);
    }
  }
}

// Once in ENU the scale is known to a few percent; fixes that would halve or
// double it cannot tell (their noise exceeds the model's extent, as on the
// first steps of a walk), and following them would collapse it.
// The fit starts from the fixes' robust placement, not from where the
// component stands: a component first placed by three fixes a metre apart
// can face any way, and a fit started there from a model turned round by
// 178 degrees stayed put while the component grew to 99 photos at 0.56 of
// its scale (bench/RESULTS.md, "Issue 35, fourteenth stop").
std::optional<Similarity> IncrementalMapper::fit_to_priors(
    const BundleOptions& ba, int component,
    const std::optional<Similarity>& start) const {
  auto sim =
      fit_model_to_priors(scene_, ba, component, start.value_or(Similarity{}));
  if (sim && sim->scale > 0.5 && sim->scale < 2 && sim->R.allFinite() &&
      sim->t.allFinite())
    return sim;
  return std::nullopt;
}

void IncrementalMapper::reset_model() {
  scene_.points.clear();
  for (SceneImage& image : scene_.images) {
    std::fill(image.point_of.begin(), image.point_of.end(), -1);
    image.registered = false;
    if (image.status == CaptureStatus::kRegistered)
      image.status = CaptureStatus::kPending;
    image.q.setIdentity();
    image.t.setZero();
  }
  scene_.initialized = false;
  scene_.geo_registered = false;
  scene_.reference_image = scene_.scale_image = -1;
  scene_.registered_at_last_global_ba = 0;
}

void IncrementalMapper::repair_after_removal() {
  // A component left with fewer than 3 photos no longer holds itself up.
  for (const auto& [component, size] : scene_.component_sizes()) {
    if (size < 3) dissolve_component(component);
  }
  if (scene_.registered_count() < 3) {
    reset_model();
    return;
  }
  auto first_registered = [&](int not_this) {
    for (size_t i = 0; i < scene_.images.size(); ++i) {
      if (scene_.images[i].registered && static_cast<int>(i) != not_this) {
        return static_cast<int>(i);
      }
    }
    return -1;
  };
  if (scene_.reference_image < 0 ||
      !scene_.images[scene_.reference_image].registered) {
    scene_.reference_image = first_registered(scene_.scale_image);
  }
  if (scene_.scale_image < 0 || !scene_.images[scene_.scale_image].registered) {
    scene_.scale_image = first_registered(scene_.reference_image);
  }
  adjust_global();
}

}  // namespace arscout::engine
