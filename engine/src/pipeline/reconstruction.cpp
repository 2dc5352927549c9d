#include "arscout/engine/reconstruction.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iterator>
#include <optional>
#include <set>
#include <stdexcept>

#include "estimators/estimators.h"
#include "features/feature_extractor.h"
#include "features/image_loader.h"
#include "features/matcher.h"
#include "io/serialization.h"
#include "pipeline/prepared_capture.h"
#include "runtime/parallel.h"
#include "runtime/stopwatch.h"
#include "scene/scene.h"
#include "sfm/mapper.h"
#include "sfm/model_builder.h"
#include "sfm/pair_selection.h"

namespace arscout::engine {
namespace {

// Two-view verification is strict: its inliers seed every track.
constexpr double kEssentialThresholdPx = 1.0;

// When two sites' scenes join: the photos of the other nearest this one's,
// each matched with this many of its nearest photos here.
constexpr size_t kAcrossPhotos = 8;
constexpr size_t kAcrossPartners = 3;

// A pair to match and verify: a new image, an earlier one, and the quarter
// turns that align the new one's descriptors with the earlier one's.
struct PairTask {
  int index = 0;
  int other = 0;
  int turns = 0;
};

std::string camera_key(const CaptureInput& capture) {
  if (!capture.camera_id.empty()) return capture.camera_id;
  return "capture:" + capture.id;  // no shared camera named: its own
}

}  // namespace

struct Reconstruction::Impl {
  ReconstructionOptions options;
  Scene scene;
  std::map<int, Undistorter> undistorters;  // per camera; rebuilt on demand

  int camera_for(const CaptureInput& capture, const WorkingImage& image);
  const PreparedCapture::Impl* usable(const CaptureInput& capture,
                                      const PreparedCapture::Impl* prepared,
                                      int* camera);
  PreparedCapture::Impl prepare_here(const CaptureInput& capture,
                                     const PreparedCapture::Impl* prepared,
                                     int* camera);
  const Undistorter& undistorter(int camera, cv::Size size);
  int match_image(int index, StageTimings& timings);
  std::optional<ImagePair> verified_pair(const PairTask& task,
                                         int threads) const;
  int verify_pairs(const std::vector<PairTask>& tasks);
  int match_across(int first);
  void set_gps(SceneImage& image, const std::optional<GeoFix>& fix);
};

int Reconstruction::Impl::camera_for(const CaptureInput& capture,
                                     const WorkingImage& image) {
  const std::string key = camera_key(capture);
  for (size_t i = 0; i < scene.cameras.size(); ++i) {
    const SceneCamera& camera = scene.cameras[i];
    if (camera.id != key) continue;
    if (camera.original.width != image.original_width ||
        camera.original.height != image.original_height) {
      throw std::invalid_argument("capture " + capture.id + " is " +
                                  std::to_string(image.original_width) + "x" +
                                  std::to_string(image.original_height) +
                                  " but camera " + key + " is " +
                                  std::to_string(camera.original.width) + "x" +
                                  std::to_string(camera.original.height));
    }
    return static_cast<int>(i);
  }
  SceneCamera camera;
  camera.id = key;
  camera.original =
      first_intrinsics(capture, image.original_width, image.original_height);
  camera.scale = image.scale;
  const cv::Matx33d k = working_k(camera.original, image.scale);
  camera.params = {k(0, 0), k(1, 1), k(0, 2), k(1, 2), 0, 0};
  camera.refine = options.refine_intrinsics == "on" ||
                  (options.refine_intrinsics == "auto" &&
                   camera.original.source != "calibrated");
  scene.cameras.push_back(camera);
  return static_cast<int>(scene.cameras.size() - 1);
}

const Undistorter& Reconstruction::Impl::undistorter(int camera,
                                                     cv::Size size) {
  auto it = undistorters.find(camera);
  if (it == undistorters.end()) {
    const SceneCamera& c = scene.cameras[camera];
    it = undistorters.emplace(camera, Undistorter(c.original, c.scale, size))
             .first;
  }
  return it->second;
}

void Reconstruction::Impl::set_gps(SceneImage& image,
                                   const std::optional<GeoFix>& fix) {
  image.gps = fix;
  if (!fix) return;
  if (!scene.enu_origin)
    scene.enu_origin = Geodetic{fix->lat, fix->lon, fix->alt.value_or(0)};
  const EnuFrame frame(*scene.enu_origin);
  const auto enu = frame.to_enu(
      {fix->lat, fix->lon, fix->alt.value_or(scene.enu_origin->alt)});
  image.gps_enu = {enu[0], enu[1], enu[2]};
}

int Reconstruction::Impl::match_image(int index, StageTimings& timings) {
  const auto start = std::chrono::steady_clock::now();
  std::vector<PairTask> tasks;
  for (const auto& [other_index, turns] :
       PairSelector(scene, options).neighbours(index))
    tasks.push_back({index, other_index, turns});
  const int verified = verify_pairs(tasks);
  timings.matching_s += seconds_since(start);
  return verified;
}

// Matches and verifies the pairs, several at once on up to options.threads
// cores, each pair's match then on one core (a lone pair's match spreads
// over them instead), and keeps those that verify. A pair's result does not
// depend on the thread that made it, and they are stored in the order
// given, so the scene does not depend on the threads.
int Reconstruction::Impl::verify_pairs(const std::vector<PairTask>& tasks) {
  std::vector<std::optional<ImagePair>> found(tasks.size());
  const int match_threads = tasks.size() > 1 ? 1 : options.threads;
  run_tasks(tasks.size(), options.threads, [&](size_t k) {
    found[k] = verified_pair(tasks[k], match_threads);
  });
  int verified = 0;
  for (size_t k = 0; k < tasks.size(); ++k) {
    if (!found[k]) continue;
    scene.pairs[{tasks[k].other, tasks[k].index}] = std::move(*found[k]);
    ++verified;
  }
  return verified;
}

// Matches the task's image (its descriptors turned by its quarter turns)
// with the earlier one: the pair when the essential matrix verifies it.
std::optional<ImagePair> Reconstruction::Impl::verified_pair(
    const PairTask& task, int threads) const {
  const SceneImage& image = scene.images[task.index];
  const SceneCamera& camera = scene.cameras[image.camera];
  const SceneImage& other = scene.images[task.other];
  const SceneCamera& other_camera = scene.cameras[other.camera];
  const auto matches = match_descriptors(
      matched_descriptors(scene, options, task.other),
      rotate_descriptors(matched_descriptors(scene, options, task.index),
                         task.turns),
      options.ratio, threads);
  std::vector<Eigen::Vector2d> x1, x2;
  for (const auto& [a, b] : matches) {
    x1.push_back(normalize(other_camera, other.keypoints[a]));
    x2.push_back(normalize(camera, image.keypoints[b]));
  }
  const double threshold =
      kEssentialThresholdPx * 2 / (camera.params[0] + other_camera.params[0]);
  const auto pose =
      estimate_relative_pose(x1, x2, threshold, options.min_pair_inliers);
  if (!pose) return std::nullopt;
  ImagePair pair;
  for (int i : pose->inliers) pair.matches.push_back(matches[i]);
  pair.R = pose->R;
  pair.t = pose->t;
  pair.median_angle_deg = pose->median_angle_deg;
  pair.homography_ratio = pose->homography_ratio;
  return pair;
}

// After absorbing another scene (its photos from `first` on): the absorbed
// photos nearest this scene's own are matched with their nearest own
// photos, a bounded number (the two sites met where their photos are
// close). Returns the pairs verified.
int Reconstruction::Impl::match_across(int first) {
  std::vector<std::pair<double, int>> nearest;  // (distance to ours, theirs)
  for (int j = first; j < static_cast<int>(scene.images.size()); ++j) {
    if (scene.images[j].removed || scene.images[j].keypoints.empty()) continue;
    double best = options.gps_radius_m;
    for (int i = 0; i < first; ++i) {
      if (scene.images[i].removed || !scene.images[i].gps) continue;
      best = std::min(
          best, (believed_position(scene, i) - believed_position(scene, j))
                    .head<2>()
                    .norm());
    }
    if (best < options.gps_radius_m) nearest.push_back({best, j});
  }
  std::sort(nearest.begin(), nearest.end());
  if (nearest.size() > kAcrossPhotos) nearest.resize(kAcrossPhotos);
  std::vector<PairTask> tasks;
  for (const auto& [distance, j] : nearest) {
    std::vector<std::pair<double, int>> ours;
    for (int i = 0; i < first; ++i) {
      if (scene.images[i].removed || !scene.images[i].gps) continue;
      ours.push_back(
          {(believed_position(scene, i) - believed_position(scene, j))
               .head<2>()
               .norm(),
           i});
    }
    std::sort(ours.begin(), ours.end());
    for (size_t k = 0; k < ours.size() && k < kAcrossPartners; ++k)
      tasks.push_back({j, ours[k].second, 0});
  }
  return verify_pairs(tasks);
}

Reconstruction::Reconstruction(ReconstructionOptions options)
    : impl_(std::make_unique<Impl>()) {
  impl_->options = std::move(options);
}
Reconstruction::~Reconstruction() = default;
Reconstruction::Reconstruction(Reconstruction&&) noexcept = default;
Reconstruction& Reconstruction::operator=(Reconstruction&&) noexcept = default;

AddResult Reconstruction::add_capture(const CaptureInput& capture) {
  return add_capture(capture, PreparedCapture());
}

// The prepared photo when it was made for this capture and the camera the
// scene holds for it; the camera's index in `camera` either way (a new one
// is added).
const PreparedCapture::Impl* Reconstruction::Impl::usable(
    const CaptureInput& capture, const PreparedCapture::Impl* prepared,
    int* camera) {
  if (!prepared || prepared->capture_id != capture.id) return nullptr;
  WorkingImage sizes;
  sizes.original_width = prepared->original_width;
  sizes.original_height = prepared->original_height;
  sizes.scale = prepared->scale;
  *camera = camera_for(capture, sizes);
  const SceneCamera& held = scene.cameras[*camera];
  if (held.scale != prepared->scale ||
      !same_geometry(held.original, prepared->intrinsics))
    return nullptr;
  return prepared;
}

// The capture decoded, undistorted through its camera and described (or
// what was prepared ahead, when usable); its camera in `camera`.
PreparedCapture::Impl Reconstruction::Impl::prepare_here(
    const CaptureInput& capture, const PreparedCapture::Impl* prepared,
    int* camera) {
  if (const PreparedCapture::Impl* ready = usable(capture, prepared, camera)) {
    PreparedCapture::Impl copy = *ready;
    copy.timings = StageTimings{};  // spent elsewhere, before this call
    return copy;
  }
  PreparedCapture::Impl here;
  const WorkingImage working = decode_capture(capture, options, here.timings);
  *camera = camera_for(capture, working);
  here.width = working.color.cols;
  here.height = working.color.rows;
  here.features = describe(working, undistorter(*camera, working.color.size()),
                           options, here.timings);
  return here;
}

AddResult Reconstruction::add_capture(const CaptureInput& capture,
                                      const PreparedCapture& prepared) {
  const auto start = std::chrono::steady_clock::now();
  Scene& scene = impl_->scene;
  const ReconstructionOptions& options = impl_->options;
  if (capture.id.empty()) throw std::invalid_argument("a capture needs an id");
  if (scene.find_image(capture.id) >= 0) {
    throw std::invalid_argument("capture " + capture.id +
                                " is already in the model");
  }
  check_camera(capture);
  AddResult result;
  result.id = capture.id;
  int camera = 0;
  PreparedCapture::Impl here =
      impl_->prepare_here(capture, prepared.impl_.get(), &camera);
  StageTimings& timings = result.timings;
  timings = here.timings;
  Features& features = here.features;

  SceneImage image;
  image.id = capture.id;
  image.scout = capture.scout;
  image.camera = camera;
  image.width = here.width;
  image.height = here.height;
  image.keypoints = std::move(features.keypoints);
  image.descriptors = features.descriptors;
  image.colors = std::move(features.colors);
  image.patches = features.patches;
  image.point_of.assign(image.keypoints.size(), -1);
  impl_->set_gps(image, capture.gps);
  result.features = static_cast<int>(image.keypoints.size());
  scene.images.push_back(std::move(image));
  const int index = static_cast<int>(scene.images.size() - 1);
  result.matched_pairs = impl_->match_image(index, timings);

  IncrementalMapper mapper(scene, options, timings);
  mapper.defer_global_adjustment(capture.more_follow);
  const std::vector<int> registered = mapper.update();
  for (int i : registered) {
    if (i != index) result.also_registered.push_back(scene.images[i].id);
  }
  const SceneImage& added = scene.images[index];
  result.status =
      added.registered ? CaptureStatus::kRegistered : CaptureStatus::kPending;
  result.reason = added.registered ? "" : added.reason;
  if (!added.registered && result.matched_pairs == 0) {
    result.reason = "no verified matches with any nearby capture";
    scene.images[index].reason = result.reason;
  } else if (!added.registered && result.reason.empty()) {
    result.reason = "its matches reach no point of the model yet";
    scene.images[index].reason = result.reason;
  }
  result.pose_inliers = added.registered ? added.pose_inliers : 0;
  result.geo_registered = scene.geo_registered;
  result.loops_closed = mapper.loops_closed();
  result.global_adjustments = mapper.global_adjustments();
  result.components_merged = mapper.components_merged();
  result.components_retired = mapper.components_retired();
  result.component = added.registered ? added.component : -1;
  timings.total_s = seconds_since(start);
  return result;
}

AbsorbResult Reconstruction::absorb(Reconstruction&& other) {
  Scene& scene = impl_->scene;
  Scene& theirs = other.impl_->scene;
  const auto placed = [](const Scene& s) {
    return s.enu_origin && (s.registered_count() == 0 || s.geo_registered);
  };
  if (!placed(scene) || !placed(theirs))
    throw std::invalid_argument(
        "only models in the sites' ENU frames can join (a site without GPS "
        "fixes cannot)");
  for (const SceneImage& image : theirs.images) {
    if (!image.removed && scene.find_image(image.id) >= 0)
      throw std::invalid_argument("capture " + image.id + " is in both");
  }
  const int first = static_cast<int>(scene.images.size());
  AbsorbResult result;
  result.captures = static_cast<int>(theirs.images.size());
  absorb_scene(scene, std::move(theirs));
  other.impl_->scene = Scene{};
  result.pairs_across = impl_->match_across(first);
  StageTimings timings;
  IncrementalMapper mapper(scene, impl_->options, timings);
  for (int i : mapper.update()) result.registered.push_back(scene.images[i].id);
  mapper.sweep_merges({});
  result.components_merged = mapper.components_merged();
  return result;
}

bool Reconstruction::remove_capture(const std::string& id) {
  Scene& scene = impl_->scene;
  const int index = scene.find_image(id);
  if (index < 0) return false;
  SceneImage& image = scene.images[index];
  for (size_t k = 0; k < image.point_of.size(); ++k)
    scene.remove_observation({index, static_cast<int>(k)});
  std::erase_if(scene.pairs, [index](const auto& entry) {
    return entry.first.first == index || entry.first.second == index;
  });
  image.removed = true;
  image.registered = false;
  image.keypoints.clear();
  image.descriptors = cv::Mat();
  image.colors.clear();
  image.patches = cv::Mat();
  image.refined_keypoints.clear();
  image.point_of.clear();
  StageTimings timings;
  IncrementalMapper mapper(scene, impl_->options, timings);
  mapper.repair_after_removal();
  mapper.update();
  return true;
}

RefineResult Reconstruction::refine(const std::function<bool()>& stop) {
  StageTimings timings;
  IncrementalMapper mapper(impl_->scene, impl_->options, timings);
  return mapper.refine(stop);
}

bool Reconstruction::refinement_due() const {
  StageTimings timings;
  IncrementalMapper mapper(impl_->scene, impl_->options, timings);
  return mapper.refinement_due();
}

bool Reconstruction::refinement_urgent() const {
  StageTimings timings;
  IncrementalMapper mapper(impl_->scene, impl_->options, timings);
  return mapper.refinement_urgent();
}

std::vector<CaptureState> Reconstruction::captures() const {
  std::vector<CaptureState> states;
  for (const SceneImage& image : impl_->scene.images) {
    if (image.removed) continue;
    states.push_back(
        {image.id, image.registered ? CaptureStatus::kRegistered : image.status,
         image.registered ? "" : image.reason,
         image.registered ? image.component : -1});
  }
  return states;
}

int Reconstruction::registered_count() const {
  return impl_->scene.registered_count();
}

std::string Reconstruction::serialize(bool features_apart) const {
  return serialize_scene(impl_->scene, features_apart);
}

std::vector<std::string> Reconstruction::captures_with_features() const {
  std::vector<std::string> ids;
  for (const SceneImage& image : impl_->scene.images)
    if (!image.keypoints.empty()) ids.push_back(image.id);
  return ids;
}

bool Reconstruction::has_features(const std::string& capture) const {
  const int index = impl_->scene.find_image(capture);
  return index >= 0 && !impl_->scene.images[index].keypoints.empty();
}

std::string Reconstruction::capture_features(const std::string& capture) const {
  const int index = impl_->scene.find_image(capture);
  if (!has_features(capture))
    throw std::invalid_argument("no features of capture " + capture);
  return serialize_features(impl_->scene.images[index]);
}

Reconstruction Reconstruction::restore(
    const std::string& bytes, ReconstructionOptions options,
    const std::function<std::string(const std::string&)>& features) {
  Reconstruction result(std::move(options));
  result.impl_->scene = deserialize_scene(bytes, features);
  result.impl_->scene.registration_backlog = true;
  return result;
}

Model Reconstruction::model() const { return build_model(impl_->scene); }

double Reconstruction::mean_reprojection_px() const {
  return engine::mean_reprojection_px(impl_->scene);
}

}  // namespace arscout::engine
