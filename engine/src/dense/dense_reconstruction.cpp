#include "arscout/engine/dense_reconstruction.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <list>
#include <set>
#include <stdexcept>
#include <unordered_map>

#include <Eigen/Dense>

#include "dense/consistency.h"
#include "dense/depth_map_io.h"
#include "dense/map_fusion.h"
#include "dense/view_coverage.h"
#include "features/image_loader.h"
#include "runtime/stopwatch.h"

namespace arscout::engine {
namespace {

using Clock = std::chrono::steady_clock;

Eigen::Matrix3d rotation_of(const ModelImage& image) {
  const auto& q = image.qvec;
  return Eigen::Quaterniond(q[0], q[1], q[2], q[3])
      .normalized()
      .toRotationMatrix();
}

Eigen::Vector3d translation_of(const ModelImage& image) {
  return {image.tvec[0], image.tvec[1], image.tvec[2]};
}

Eigen::Vector3d centre_of(const ModelImage& image) {
  return -rotation_of(image).transpose() * translation_of(image);
}

// Which images see which points, for neighbour choice and depth ranges.
class Covisibility {
 public:
  explicit Covisibility(const Model& model) : model_(model) {
    for (size_t i = 0; i < model.points.size(); ++i)
      point_index_[model.points[i].id] = i;
  }

  std::vector<const ModelPoint*> points_of(int image) const {
    std::vector<const ModelPoint*> points;
    for (int64_t id : model_.images[image].point_ids) {
      if (id < 0) continue;
      auto it = point_index_.find(id);
      if (it != point_index_.end())
        points.push_back(&model_.points[it->second]);
    }
    return points;
  }

  // Images sharing points with `image`: count of shared points, and the
  // median angle between the two cameras' rays to them.
  struct Shared {
    int image = 0;
    int count = 0;
    double median_angle_deg = 0;
  };
  std::vector<Shared> shared_with(int image) const {
    std::map<int, std::vector<double>> angles;
    const Eigen::Vector3d c = centre_of(model_.images[image]);
    for (const ModelPoint* point : points_of(image)) {
      const Eigen::Vector3d X(point->xyz[0], point->xyz[1], point->xyz[2]);
      for (const auto& [other, keypoint] : point->track) {
        if (other == image) continue;
        const Eigen::Vector3d o = centre_of(model_.images[other]);
        const double cosine = (c - X).normalized().dot((o - X).normalized());
        angles[other].push_back(std::acos(std::clamp(cosine, -1.0, 1.0)) * 180 /
                                M_PI);
      }
    }
    std::vector<Shared> result;
    for (auto& [other, list] : angles) {
      auto middle = list.begin() + list.size() / 2;
      std::nth_element(list.begin(), middle, list.end());
      result.push_back({other, static_cast<int>(list.size()), *middle});
    }
    std::sort(
        result.begin(), result.end(), [](const Shared& a, const Shared& b) {
          return a.count != b.count ? a.count > b.count : a.image < b.image;
        });
    return result;
  }

 private:
  const Model& model_;
  std::unordered_map<int64_t, size_t> point_index_;
};

constexpr int kMinSharedPoints = 20;

// The best-connected images whose baseline angle is in range; failing
// those, the best-connected with at least half the minimum angle.
std::vector<int> choose_neighbours(const Covisibility& covisibility, int key,
                                   const DenseOptions& options) {
  const auto shared = covisibility.shared_with(key);
  std::vector<int> chosen;
  for (const auto& s : shared) {
    if (static_cast<int>(chosen.size()) >= options.neighbours) break;
    if (s.count >= kMinSharedPoints &&
        s.median_angle_deg >= options.min_angle_deg &&
        s.median_angle_deg <= options.max_angle_deg)
      chosen.push_back(s.image);
  }
  for (const auto& s : shared) {
    if (static_cast<int>(chosen.size()) >= options.neighbours) break;
    if (s.count >= kMinSharedPoints &&
        s.median_angle_deg >= options.min_angle_deg / 2 &&
        std::find(chosen.begin(), chosen.end(), s.image) == chosen.end())
      chosen.push_back(s.image);
  }
  return chosen;
}

// The site's up once the model is in ENU; unknown before.
Eigen::Vector3d world_up(const Model& model) {
  if (model.geo_registered) return Eigen::Vector3d::UnitZ();
  return Eigen::Vector3d::Zero();
}

DenseView load_view(const Model& model, int index, const ImageSource& images,
                    const Covisibility& covisibility, int long_side) {
  const ModelImage& image = model.images[index];
  const CameraIntrinsics& camera = model.cameras.at(image.camera).intrinsics;
  const WorkingImage working = decode_working_image(
      images(image.id), long_side, cv::Size(camera.width, camera.height));
  DenseView view;
  view.id = image.id;
  const Undistorter undistorter(camera, working.scale, working.color.size());
  view.bgr = undistorter.apply(working.color);
  const cv::Matx33d k = working_k(camera, working.scale);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) view.K(r, c) = k(r, c);
  view.R = rotation_of(image);
  view.t = translation_of(image);
  view.up = world_up(model);
  for (const ModelPoint* point : covisibility.points_of(index))
    view.sparse_points.emplace_back(point->xyz[0], point->xyz[1],
                                    point->xyz[2]);
  return view;
}

// The decoded views most recently used, so that a neighbour swept against
// by several new key views is decoded once.
class ViewCache {
 public:
  explicit ViewCache(size_t capacity) : capacity_(capacity) {}

  const DenseView& get(const Model& model, int index, const ImageSource& images,
                       const Covisibility& covisibility, int long_side) {
    const std::string& id = model.images[index].id;
    for (auto it = views_.begin(); it != views_.end(); ++it) {
      if (it->id != id) continue;
      views_.splice(views_.begin(), views_, it);
      // Poses and points move with every adjustment: refresh them.
      DenseView& view = views_.front();
      view.R = rotation_of(model.images[index]);
      view.t = translation_of(model.images[index]);
      view.up = world_up(model);
      view.sparse_points.clear();
      for (const ModelPoint* p : covisibility.points_of(index))
        view.sparse_points.emplace_back(p->xyz[0], p->xyz[1], p->xyz[2]);
      return view;
    }
    views_.push_front(load_view(model, index, images, covisibility, long_side));
    if (views_.size() > capacity_) views_.pop_back();
    return views_.front();
  }

  void forget(const std::string& id) {
    views_.remove_if([&](const DenseView& v) { return v.id == id; });
  }

 private:
  size_t capacity_;
  std::list<DenseView> views_;
};

double median_depth(const cv::Mat& depth) {
  std::vector<float> depths;
  for (int y = 0; y < depth.rows; ++y)
    for (int x = 0; x < depth.cols; ++x)
      if (depth.at<float>(y, x) > 0) depths.push_back(depth.at<float>(y, x));
  if (depths.empty()) return 0;
  auto middle = depths.begin() + depths.size() / 2;
  std::nth_element(depths.begin(), middle, depths.end());
  return *middle;
}

// The median, over `points`, of the point's depth in the map's camera (at
// its current pose) over `depth` at the pixel the point falls on; 0 with
// fewer than kMinSharedPoints such points. It changes when the model
// changes scale around this camera.
double sparse_depth_ratio(const DepthMap& map, const cv::Mat& depth,
                          const std::vector<const ModelPoint*>& points) {
  std::vector<double> ratios;
  for (const ModelPoint* point : points) {
    const Eigen::Vector3d in_camera =
        map.R * Eigen::Vector3d(point->xyz[0], point->xyz[1], point->xyz[2]) +
        map.t;
    if (!(in_camera.z() > 0) || !in_camera.allFinite()) continue;
    const Eigen::Vector3d pixel = map.K * in_camera;
    const long x = std::lround(pixel.x() / pixel.z());
    const long y = std::lround(pixel.y() / pixel.z());
    if (x < 0 || y < 0 || x >= depth.cols || y >= depth.rows) continue;
    const float at = depth.at<float>(static_cast<int>(y), static_cast<int>(x));
    if (at > 0) ratios.push_back(in_camera.z() / at);
  }
  if (ratios.size() < static_cast<size_t>(kMinSharedPoints)) return 0;
  auto middle = ratios.begin() + ratios.size() / 2;
  std::nth_element(ratios.begin(), middle, ratios.end());
  return *middle;
}

}  // namespace

PlaneSweepOptions catch_up_sweep(const PlaneSweepOptions& sweep) {
  PlaneSweepOptions coarse = sweep;
  coarse.plane_step_px = 2 * sweep.plane_step_px;
  coarse.min_planes = std::max(1, sweep.min_planes / 2);
  coarse.max_planes = std::max(coarse.min_planes, sweep.max_planes / 2);
  return coarse;
}

struct DenseReconstruction::Impl {
  struct Entry {
    DepthMap map;    // as swept; R, t follow the model
    cv::Mat colour;  // the key view's pixels, for the points' colours
    cv::Mat agreed;  // CV_8U: how many other maps agree (saturating)
    // CV_8U: how many are in free-space conflict with it (saturating)
    cv::Mat conflicts;
    // CV_8U: 255 where the depth is weak (weak_depths())
    cv::Mat weak;
    MapFusion fusion;  // what it put into the cloud
    // The pose of its last fusion whole; moving away from it re-fuses it.
    Eigen::Vector3d fused_centre = Eigen::Vector3d::Zero();
    Eigen::Matrix3d fused_R = Eigen::Matrix3d::Identity();
    double fused_scale = 1;  // depth_scale then
    // What serialize_depth_map() writes besides the map: the pose at sweep
    // time (map.R and map.t follow the model), the neighbours swept with,
    // the place in the order of sweeping.
    Eigen::Matrix3d swept_R = Eigen::Matrix3d::Identity();
    Eigen::Vector3d swept_t = Eigen::Vector3d::Zero();
    std::vector<std::string> neighbours;
    uint64_t sequence = 0;
    double sparse_ratio = 0;  // SweptDepthMap::sparse_depth_ratio
    // The sweep's depths once the model changed scale around this camera
    // (map.depth then holds them times depth_scale); empty before.
    cv::Mat swept_depth;
    double depth_scale = 1;
    double swept_median = -1;  // of the swept depths; -1 until asked

    // The sweep's scores, when the map has them (every swept or stored map
    // does; a hand-built one may not).
    const cv::Mat* score() const {
      return map.score.size() == map.depth.size() ? &map.score : nullptr;
    }
    const cv::Mat& depth_as_swept() const {
      return swept_depth.empty() ? map.depth : swept_depth;
    }
    double median() {
      if (swept_median < 0) swept_median = median_depth(depth_as_swept());
      return swept_median * depth_scale;
    }
    FusionInput fusion_input(int min_agreeing) const {
      return {&depth_as_swept(),
              depth_scale,
              &agreed,
              &conflicts,
              min_agreeing,
              &weak,
              score(),
              &colour,
              map.K,
              map.R,
              map.t};
    }
    // Adds one other map's word on this one to the counts (saturating):
    // `mine` is this map judged against it, `theirs` it judged against this
    // map. A pixel in conflict both ways counts once.
    void count(const PairVerdict& mine, const PairVerdict& theirs) {
      cv::add(agreed, 1, agreed, mine.agrees);
      cv::add(conflicts, 1, conflicts, mine.sees_through | theirs.overshoots);
    }
    // CV_8U, 255 where fusable().
    cv::Mat fusable_mask(int min_agreeing) const {
      cv::Mat mask = cv::Mat::zeros(agreed.size(), CV_8U);
      for (int y = 0; y < mask.rows; ++y)
        for (int x = 0; x < mask.cols; ++x)
          if (fusable(agreed.at<uint8_t>(y, x), conflicts.at<uint8_t>(y, x),
                      min_agreeing, weak.at<uint8_t>(y, x)))
            mask.at<uint8_t>(y, x) = 255;
      return mask;
    }
    // A new map's counts, and its weak depths as seen from the neighbours
    // it was swept with (their centres, world frame).
    void start_fusion(const ConsistencyOptions& options,
                      const std::vector<Eigen::Vector3d>& neighbour_centres) {
      weak = weak_depths(map, neighbour_centres, options);
      agreed = cv::Mat::zeros(map.depth.size(), CV_8U);
      conflicts = cv::Mat::zeros(map.depth.size(), CV_8U);
      fusion = MapFusion();  // a new map: its normals too
      fusion.reset(map.depth.size());
    }
  };

  explicit Impl(DenseOptions o) : options(std::move(o)), cache(32) {}

  DenseOptions options;
  ViewCache cache;
  std::map<std::string, Entry> entries;
  std::vector<std::string> order;  // of sweeping
  uint64_t next_sequence = 0;
  std::unique_ptr<VoxelCloud> cloud;
  // Maps whose agreement grew since they were last fused.
  std::set<std::string> dirty;
  // The pairs of maps checked against each other since the agreement was
  // last reset (by id, the smaller first): each pair counts once.
  std::set<std::pair<std::string, std::string>> checked_pairs;
  void reset_agreement() {
    for (auto& [id, entry] : entries) {
      entry.agreed.setTo(0);
      entry.conflicts.setTo(0);
    }
    checked_pairs.clear();
  }
  // Registered views judged not to be key views (DenseUpdate::covered).
  std::set<std::string> covered;
  // Key views the last update found no neighbour for (DenseUpdate::skipped):
  // tried again by every update, but not a backlog to catch up on.
  std::set<std::string> unswept;
  // The agreement checks' options of this moment: they ask the sweep's
  // question (DenseReconstruction::set_parallel_while) too.
  ConsistencyOptions consistency() const {
    ConsistencyOptions o = options.consistency;
    if (options.sweep.keep_parallel) o.parallel = options.sweep.keep_parallel();
    return o;
  }

  bool drop_withdrawn(const std::map<std::string, int>& index);
  std::map<std::string, double> follow_poses(
      const Model& model, const std::map<std::string, int>& index,
      const Covisibility& covisibility);
  void follow_scale(Entry& entry, const std::vector<const ModelPoint*>& points);
  std::set<std::string> within_budget(
      const std::map<std::string, double>& moved, bool sweeping) const;
  void sweep_new_views(const Model& model, const ImageSource& images,
                       const Covisibility& covisibility,
                       const std::function<void(const std::string&)>& progress,
                       DenseUpdate* update);
  double tolerance(const Entry& entry, double depth) const;
  bool redundant(const Model& model, int image,
                 const Covisibility& covisibility) const;
  bool measured_already(const Model& model, int image,
                        const Covisibility& covisibility) const;
  bool sweep(const Model& model, int key, const ImageSource& images,
             const Covisibility& covisibility,
             const PlaneSweepOptions& sweep_options, DenseUpdate* update);
  size_t waiting_views(const Model& model) const;
  void filter(const std::string& id, const Model& model,
              const std::map<std::string, int>& index,
              const Covisibility& covisibility);
  double voxel_size();
  bool fuse(bool rebuild, const std::set<std::string>& moved,
            DenseUpdate* update);
};

bool DenseReconstruction::Impl::drop_withdrawn(
    const std::map<std::string, int>& index) {
  bool dropped = false;
  for (auto it = entries.begin(); it != entries.end();) {
    if (index.count(it->first)) {
      ++it;
      continue;
    }
    cache.forget(it->first);
    order.erase(std::find(order.begin(), order.end(), it->first));
    it = entries.erase(it);
    dropped = true;
  }
  // A withdrawn key view may have covered others: judge them again.
  if (dropped) covered.clear();
  std::erase_if(covered,
                [&](const std::string& id) { return !index.count(id); });
  return dropped;
}

// Whether the maps held already measure what `image` sees: enough of its
// sparse points are each observed by redundant_observers key views.
bool DenseReconstruction::Impl::redundant(
    const Model& model, int image, const Covisibility& covisibility) const {
  if (!(options.redundant_share > 0 && options.redundant_share <= 1))
    return false;
  const std::vector<const ModelPoint*> points = covisibility.points_of(image);
  if (points.size() < static_cast<size_t>(kMinSharedPoints)) return false;
  size_t measured = 0;
  for (const ModelPoint* point : points) {
    int observers = 0;
    for (const auto& [other, keypoint] : point->track)
      observers += other != image && entries.count(model.images[other].id);
    measured += observers >= options.redundant_observers;
  }
  return measured >= options.redundant_share * points.size();
}

// Whether the maps of the key views best connected to `image` already
// measure nearly all of its picture (DenseOptions::new_coverage_share).
bool DenseReconstruction::Impl::measured_already(
    const Model& model, int image, const Covisibility& covisibility) const {
  if (!(options.new_coverage_share > 0 && options.new_coverage_share <= 1))
    return false;
  std::vector<const DepthMap*> maps;
  for (const auto& shared : covisibility.shared_with(image)) {
    if (static_cast<int>(maps.size()) >= options.consistency_partners) break;
    auto it = entries.find(model.images[shared.image].id);
    if (it != entries.end()) maps.push_back(&it->second.map);
  }
  if (maps.empty()) return false;
  const ModelImage& view = model.images[image];
  std::vector<std::array<double, 2>> keypoints;
  for (size_t k = 0; k < view.keypoints.size() && k < view.point_ids.size();
       ++k)
    if (view.point_ids[k] >= 0) keypoints.push_back(view.keypoints[k]);
  if (keypoints.size() < static_cast<size_t>(kMinSharedPoints)) return false;
  return measured_share(model.cameras[view.camera].intrinsics,
                        rotation_of(view), translation_of(view), keypoints,
                        maps) >= options.new_coverage_share;
}

// How far a map's surface may move before the cloud is re-fused: a share
// of a voxel (of the voxel the map's own footprint would give while there
// is no cloud yet).
double DenseReconstruction::Impl::tolerance(const Entry& entry,
                                            double depth) const {
  const double voxel =
      cloud ? cloud->voxel_size() : 1.5 * depth / entry.map.K(0, 0);
  return options.refuse_fraction * voxel;
}

// A map follows its camera's pose, but a model can also change scale
// around a camera (a geo-registration from a few GPS fixes, a global
// adjustment): the depths the sweep measured then no longer meet the
// sparse points. The ratio of sparse to swept depths, against the sweep's
// own, gives the change; the map is rescaled by it when its surface moves
// by more than the tolerance.
// A map without a sweep-time ratio (a version 1 map, or too few points
// then) takes today's as its reference.
void DenseReconstruction::Impl::follow_scale(
    Entry& entry, const std::vector<const ModelPoint*>& points) {
  const double ratio =
      sparse_depth_ratio(entry.map, entry.depth_as_swept(), points);
  if (!(ratio > 0)) return;
  if (!(entry.sparse_ratio > 0)) {
    entry.sparse_ratio = ratio;
    return;
  }
  const double scale = ratio / entry.sparse_ratio;
  const double depth = entry.median();
  if (std::abs(scale - entry.depth_scale) * depth <= tolerance(entry, depth))
    return;
  if (entry.swept_depth.empty()) entry.swept_depth = entry.map.depth.clone();
  entry.map.depth = entry.swept_depth * scale;
  entry.depth_scale = scale;
}

// Moves every map to its camera's current pose and scale; returns the maps
// that moved enough since their fusion to be fused again, each with how
// many tolerances it moved.
std::map<std::string, double> DenseReconstruction::Impl::follow_poses(
    const Model& model, const std::map<std::string, int>& index,
    const Covisibility& covisibility) {
  std::map<std::string, double> moved;
  for (auto& [id, entry] : entries) {
    const ModelImage& image = model.images[index.at(id)];
    entry.map.R = rotation_of(image);
    entry.map.t = translation_of(image);
    follow_scale(entry, covisibility.points_of(index.at(id)));
    if (!cloud) continue;  // nothing fused yet
    const double depth = entry.median();
    const double allowed = tolerance(entry, depth);
    const Eigen::AngleAxisd turn(entry.map.R * entry.fused_R.transpose());
    const double by =
        std::max({(centre_of(image) - entry.fused_centre).norm(),
                  std::abs(turn.angle()) * depth,
                  std::abs(entry.depth_scale - entry.fused_scale) * depth /
                      entry.depth_scale}) /
        allowed;
    if (by > 1) moved[id] = by;
  }
  return moved;
}

// The moved maps one update re-fuses: those that moved farthest, at most
// refuse_budget of them. The others keep their points where their cameras
// were and stay moved (their fusion pose is unchanged), so a later update
// takes them.
std::set<std::string> DenseReconstruction::Impl::within_budget(
    const std::map<std::string, double>& moved, bool sweeping) const {
  std::vector<std::pair<double, std::string>> farthest;
  for (const auto& [id, by] : moved) farthest.emplace_back(by, id);
  std::sort(farthest.begin(), farthest.end(), std::greater<>());
  const int budget = sweeping && options.refuse_budget_sweeping >= 0
                         ? options.refuse_budget_sweeping
                         : options.refuse_budget;
  if (budget > 0 && farthest.size() > static_cast<size_t>(budget))
    farthest.resize(budget);
  std::set<std::string> chosen;
  for (const auto& [by, id] : farthest) chosen.insert(id);
  return chosen;
}

// Sweeps `key`'s depth map; false when it has no neighbour to sweep with.
bool DenseReconstruction::Impl::sweep(const Model& model, int key,
                                      const ImageSource& images,
                                      const Covisibility& covisibility,
                                      const PlaneSweepOptions& sweep_options,
                                      DenseUpdate* update) {
  const std::vector<int> neighbour_indices =
      choose_neighbours(covisibility, key, options);
  const std::string& id = model.images[key].id;
  if (neighbour_indices.empty()) {
    update->skipped.push_back(id);
    unswept.insert(id);
    return false;
  }
  unswept.erase(id);
  const DenseView key_view =
      cache.get(model, key, images, covisibility, options.long_side);
  std::vector<DenseView> neighbour_views;
  for (int n : neighbour_indices)
    neighbour_views.push_back(
        cache.get(model, n, images, covisibility, options.long_side));
  std::vector<const DenseView*> neighbours;
  for (const DenseView& v : neighbour_views) neighbours.push_back(&v);
  Entry entry;
  entry.map = sweep_planes(key_view, neighbours, sweep_options);
  round_to_kept_precision(entry.map);  // as stored: a restore is exact
  entry.swept_R = entry.map.R;
  entry.swept_t = entry.map.t;
  entry.sparse_ratio = sparse_depth_ratio(entry.map, entry.map.depth,
                                          covisibility.points_of(key));
  for (int n : neighbour_indices)
    entry.neighbours.push_back(model.images[n].id);
  entry.sequence = next_sequence++;
  entry.colour = key_view.bgr;
  std::vector<Eigen::Vector3d> centres;
  for (const DenseView& v : neighbour_views) centres.push_back(v.centre());
  entry.start_fusion(options.consistency, centres);
  entries[id] = std::move(entry);
  order.push_back(id);
  update->new_depth_maps.push_back(id);
  return true;
}

// Registered views that have no map, were not judged covered and did not
// lack neighbours last time: an upper bound of the sweeps still to do.
size_t DenseReconstruction::Impl::waiting_views(const Model& model) const {
  size_t waiting = 0;
  for (const ModelImage& image : model.images)
    waiting += !entries.count(image.id) && !covered.count(image.id) &&
               !unswept.count(image.id);
  return waiting;
}

// Sweeps the registered views that have no map and are key views, in the
// model's order (the order of registration), at most sweep_budget of them;
// the views past the budget are counted in deferred_views and judged by a
// later update. Behind by more than catch_up_backlog views, it sweeps with
// catch_up_sweep.
void DenseReconstruction::Impl::sweep_new_views(
    const Model& model, const ImageSource& images,
    const Covisibility& covisibility,
    const std::function<void(const std::string&)>& progress,
    DenseUpdate* update) {
  const bool catching_up =
      options.catch_up_backlog > 0 &&
      waiting_views(model) > static_cast<size_t>(options.catch_up_backlog);
  const PlaneSweepOptions sweep_options =
      catching_up ? catch_up_sweep(options.sweep) : options.sweep;
  for (size_t i = 0; i < model.images.size(); ++i) {
    const std::string& id = model.images[i].id;
    if (entries.count(id) || covered.count(id)) continue;
    if (options.sweep_budget > 0 &&
        update->new_depth_maps.size() >=
            static_cast<size_t>(options.sweep_budget)) {
      ++update->deferred_views;
      continue;
    }
    if (redundant(model, static_cast<int>(i), covisibility) ||
        measured_already(model, static_cast<int>(i), covisibility)) {
      covered.insert(id);
      update->covered.push_back(id);
      continue;
    }
    if (progress) progress(id);
    if (sweep(model, static_cast<int>(i), images, covisibility, sweep_options,
              update) &&
        catching_up)
      ++update->caught_up_maps;
  }
}

void DenseReconstruction::Impl::filter(const std::string& id,
                                       const Model& model,
                                       const std::map<std::string, int>& index,
                                       const Covisibility& covisibility) {
  Entry& entry = entries.at(id);
  int partners = 0;
  for (const auto& shared : covisibility.shared_with(index.at(id))) {
    if (partners >= options.consistency_partners) break;
    auto other = entries.find(model.images[shared.image].id);
    if (other == entries.end()) continue;
    ++partners;
    if (!checked_pairs.insert(std::minmax(id, other->first)).second) continue;
    dirty.insert(id);
    dirty.insert(other->first);
    const PairVerdict mine =
        judge_pair(entry.map, other->second.map, consistency());
    const PairVerdict theirs =
        judge_pair(other->second.map, entry.map, consistency());
    entry.count(mine, theirs);
    other->second.count(theirs, mine);
  }
}

// The voxel edge: the option's, or 1.5 pixel footprints at the median depth
// of the first map (0 while there is none). A map rescaled with its model
// rescales the voxel with it.
double DenseReconstruction::Impl::voxel_size() {
  double size = options.voxel_size;
  for (const std::string& id : order) {
    if (size > 0) break;
    Entry& e = entries.at(id);
    const double depth = e.median();
    if (depth > 0) size = 1.5 * depth / e.map.K(0, 0);
  }
  return size;
}

// Whether the derived voxel edge moved far enough from the cloud's to fuse
// every map afresh at it. The edge is a resolution (1.5 pixel footprints),
// and the first map's depths follow every small change of the model's
// scale around it: a rebuild for each would cost the whole site per
// increment. A scale change of a tenth or more (a model that settles its
// scale, or geo-registration) still rebuilds.
namespace {
bool voxel_edge_changed(double current, double derived) {
  constexpr double kVoxelTolerance = 0.1;
  return std::abs(derived - current) > kVoxelTolerance * current;
}
}  // namespace

// Brings the cloud up to the maps: all of them fused afresh when `rebuild`
// (or the voxel edge changed); else each moved map taken out and fused
// again at its new pose, and the pixels that came to agree since added.
// Costs what the moved and newly agreeing maps hold, not the site. True
// when every map was fused afresh.
bool DenseReconstruction::Impl::fuse(bool rebuild,
                                     const std::set<std::string>& moved,
                                     DenseUpdate* update) {
  const double size = voxel_size();
  if (!(size > 0)) return false;
  if (!cloud || voxel_edge_changed(cloud->voxel_size(), size)) {
    rebuild = rebuild || cloud;  // a new voxel edge: every map again
    cloud = std::make_unique<VoxelCloud>(size);
    for (auto& [id, entry] : entries)
      entry.fusion.reset(entry.map.depth.size());
  }
  if (rebuild) {
    cloud->clear();
    for (auto& [id, entry] : entries)
      entry.fusion.reset(entry.map.depth.size());
  }
  for (const std::string& id : order) {
    Entry& entry = entries.at(id);
    const bool again = !rebuild && moved.count(id) && !entry.fusion.empty();
    if (!rebuild && !again && !dirty.count(id) && !moved.count(id)) continue;
    const FusionInput input =
        entry.fusion_input(options.consistency.min_agreeing_maps);
    if (again) {
      entry.fusion.remove(input, cloud.get());
      ++update->refused_maps;
    }
    const bool whole = entry.fusion.empty();
    entry.fusion.add(input, cloud.get());
    if (whole) {
      entry.fused_centre = -entry.map.R.transpose() * entry.map.t;
      entry.fused_R = entry.map.R;
      entry.fused_scale = entry.depth_scale;
    }
  }
  dirty.clear();
  return rebuild ||
         (!entries.empty() && update->refused_maps == entries.size());
}

DenseReconstruction::DenseReconstruction(DenseOptions options)
    : impl_(std::make_unique<Impl>(std::move(options))) {}
DenseReconstruction::~DenseReconstruction() = default;
DenseReconstruction::DenseReconstruction(DenseReconstruction&&) noexcept =
    default;
DenseReconstruction& DenseReconstruction::operator=(
    DenseReconstruction&&) noexcept = default;

DenseUpdate DenseReconstruction::update(
    const Model& model, const ImageSource& images,
    const std::function<void(const std::string&)>& progress) {
  DenseUpdate update;
  std::map<std::string, int> index;
  for (size_t i = 0; i < model.images.size(); ++i)
    index[model.images[i].id] = static_cast<int>(i);
  const Covisibility covisibility(model);
  const bool withdrawn = impl_->drop_withdrawn(index);
  const std::map<std::string, double> moved =
      impl_->follow_poses(model, index, covisibility);
  auto start = Clock::now();
  impl_->sweep_new_views(model, images, covisibility, progress, &update);
  update.sweep_s = seconds_since(start);
  start = Clock::now();
  // A withdrawn map no longer vouches for anyone: check every pair again.
  if (withdrawn) impl_->reset_agreement();
  for (const std::string& id : withdrawn ? impl_->order : update.new_depth_maps)
    impl_->filter(id, model, index, covisibility);
  update.filter_s = seconds_since(start);
  start = Clock::now();
  const std::set<std::string> refuse =
      impl_->within_budget(moved, !update.new_depth_maps.empty());
  update.refused = impl_->fuse(withdrawn, refuse, &update);
  update.deferred_maps = update.refused ? 0 : moved.size() - refuse.size();
  update.fusion_s = seconds_since(start);
  update.points = impl_->cloud ? impl_->cloud->size() : 0;
  return update;
}

DenseUpdate update_until_settled(DenseReconstruction& dense, const Model& model,
                                 const ImageSource& images) {
  DenseUpdate total = dense.update(model, images);
  while (total.deferred_maps > 0 || total.deferred_views > 0) {
    const DenseUpdate round = dense.update(model, images);
    // Each round sweeps or re-fuses what it leaves fewer of; should one do
    // neither, repeating it would never end.
    if (round.refused_maps == 0 && !round.refused &&
        round.new_depth_maps.empty() && round.covered.empty())
      break;
    total.new_depth_maps.insert(total.new_depth_maps.end(),
                                round.new_depth_maps.begin(),
                                round.new_depth_maps.end());
    total.skipped = round.skipped;
    total.covered.insert(total.covered.end(), round.covered.begin(),
                         round.covered.end());
    total.deferred_views = round.deferred_views;
    total.caught_up_maps += round.caught_up_maps;
    total.sweep_s += round.sweep_s;
    total.refused = total.refused || round.refused;
    total.refused_maps += round.refused_maps;
    total.deferred_maps = round.deferred_maps;
    total.points = round.points;
    total.filter_s += round.filter_s;
    total.fusion_s += round.fusion_s;
  }
  return total;
}

DenseUpdate DenseReconstruction::restore_depth_maps(
    const std::vector<std::string>& maps, const Model& model,
    const ImageSource& images) {
  DenseUpdate update;
  auto start = Clock::now();
  std::map<std::string, int> index;
  for (size_t i = 0; i < model.images.size(); ++i)
    index[model.images[i].id] = static_cast<int>(i);
  const Covisibility covisibility(model);
  // All that can fail comes first: the state is untouched until it is done.
  std::vector<SweptDepthMap> decoded;
  std::set<std::string> ids;
  for (const std::string& bytes : maps) {
    decoded.push_back(decode_depth_map(bytes));
    if (!ids.insert(decoded.back().map.id).second)
      throw std::invalid_argument("two depth maps of '" +
                                  decoded.back().map.id + "'");
  }
  std::vector<std::pair<std::string, Impl::Entry>> adopted;
  for (SweptDepthMap& swept : decoded) {
    const std::string id = swept.map.id;
    auto it = index.find(id);
    if (it == index.end() || impl_->entries.count(id)) continue;
    const cv::Mat colour = impl_->cache
                               .get(model, it->second, images, covisibility,
                                    impl_->options.long_side)
                               .bgr;
    if (colour.size() != swept.map.depth.size())
      throw std::invalid_argument(
          "the depth map of '" + id + "' is " +
          std::to_string(swept.map.depth.cols) + " x " +
          std::to_string(swept.map.depth.rows) +
          " pixels, the photo at this dense resolution " +
          std::to_string(colour.cols) + " x " + std::to_string(colour.rows));
    Impl::Entry entry;
    entry.swept_R = swept.map.R;
    entry.swept_t = swept.map.t;
    entry.neighbours = std::move(swept.neighbours);
    entry.sequence = swept.sequence;
    entry.sparse_ratio = swept.sparse_depth_ratio;
    entry.map = std::move(swept.map);
    entry.colour = colour;
    std::vector<Eigen::Vector3d> centres;  // of the neighbours still there
    for (const std::string& neighbour : entry.neighbours) {
      auto n = index.find(neighbour);
      if (n != index.end())
        centres.push_back(centre_of(model.images[n->second]));
    }
    entry.start_fusion(impl_->options.consistency, centres);
    adopted.emplace_back(id, std::move(entry));
  }
  const double loading_s = seconds_since(start);

  impl_->drop_withdrawn(index);
  for (auto& [id, entry] : adopted) {
    impl_->next_sequence = std::max(impl_->next_sequence, entry.sequence + 1);
    impl_->entries[id] = std::move(entry);
    impl_->order.push_back(id);
  }
  std::stable_sort(impl_->order.begin(), impl_->order.end(),
                   [&](const std::string& a, const std::string& b) {
                     return impl_->entries.at(a).sequence <
                            impl_->entries.at(b).sequence;
                   });
  // Every map to its camera's pose; the cloud is rebuilt whatever moved.
  impl_->dirty.clear();
  impl_->follow_poses(model, index, covisibility);
  start = Clock::now();
  // Agreement is not stored: check every pair, as after a withdrawal.
  impl_->reset_agreement();
  for (const std::string& id : impl_->order)
    impl_->filter(id, model, index, covisibility);
  update.filter_s = seconds_since(start);
  start = Clock::now();
  update.refused = impl_->fuse(true, {}, &update);
  update.fusion_s = loading_s + seconds_since(start);
  update.points = impl_->cloud ? impl_->cloud->size() : 0;
  return update;
}

std::vector<std::string> DenseReconstruction::depth_map_ids() const {
  return impl_->order;
}

std::vector<std::string> DenseReconstruction::covered_ids() const {
  return {impl_->covered.begin(), impl_->covered.end()};
}

std::string DenseReconstruction::serialize_depth_map(
    const std::string& id) const {
  auto it = impl_->entries.find(id);
  if (it == impl_->entries.end())
    throw std::invalid_argument("no depth map of '" + id + "'");
  const Impl::Entry& entry = it->second;
  SweptDepthMap swept;
  swept.map = entry.map;  // shares the pixels
  swept.map.depth = entry.depth_as_swept();
  swept.map.R = entry.swept_R;
  swept.map.t = entry.swept_t;
  swept.neighbours = entry.neighbours;
  swept.sequence = entry.sequence;
  swept.sparse_depth_ratio = entry.sparse_ratio;
  return encode_depth_map(swept);
}

std::vector<ColoredPoint> DenseReconstruction::points() const {
  return impl_->cloud ? impl_->cloud->points() : std::vector<ColoredPoint>{};
}

std::vector<CloudBlock> DenseReconstruction::cloud_blocks() const {
  return impl_->cloud ? impl_->cloud->blocks() : std::vector<CloudBlock>{};
}

double DenseReconstruction::cloud_block_edge() const {
  return impl_->cloud ? impl_->cloud->block_edge() : 0;
}

std::uint64_t DenseReconstruction::mark_cloud() {
  return impl_->cloud ? impl_->cloud->mark() : 0;
}

std::vector<ColoredPoint> DenseReconstruction::points_in(
    const Eigen::Vector2d& lo, const Eigen::Vector2d& hi) const {
  return impl_->cloud ? impl_->cloud->points_in(lo, hi)
                      : std::vector<ColoredPoint>{};
}

std::vector<DepthMap> DenseReconstruction::filtered_depth_maps() const {
  std::vector<DepthMap> maps;
  for (const std::string& id : impl_->order) {
    const auto& entry = impl_->entries.at(id);
    DepthMap map = entry.map;
    // A new buffer: `map` shares the stored one, which must stay as swept.
    map.depth = cv::Mat(entry.map.depth.size(), CV_32F, cv::Scalar(0));
    entry.map.depth.copyTo(
        map.depth,
        entry.fusable_mask(impl_->options.consistency.min_agreeing_maps));
    maps.push_back(std::move(map));
  }
  return maps;
}

std::vector<DenseReconstruction::KeyView> DenseReconstruction::key_views()
    const {
  std::vector<KeyView> views;
  for (const std::string& id : impl_->order) {
    const auto& entry = impl_->entries.at(id);
    views.push_back({entry.colour, entry.map});
  }
  return views;
}

const DepthMap* DenseReconstruction::raw_depth_map(
    const std::string& id) const {
  auto it = impl_->entries.find(id);
  return it == impl_->entries.end() ? nullptr : &it->second.map;
}

void DenseReconstruction::set_parallel_while(std::function<bool()> while_true) {
  impl_->options.sweep.parallel = true;
  impl_->options.consistency.parallel = true;
  impl_->options.sweep.keep_parallel = std::move(while_true);
}

void DenseReconstruction::set_parallel(bool parallel) {
  impl_->options.sweep.parallel = parallel;
  impl_->options.sweep.keep_parallel = nullptr;
  impl_->options.consistency.parallel = parallel;
}

double DenseReconstruction::voxel_size() const {
  return impl_->cloud ? impl_->cloud->voxel_size() : 0;
}

DepthMap compute_key_depth_map(const Model& model, const std::string& key_id,
                               const ImageSource& images,
                               const DenseOptions& options) {
  int key = -1;
  for (size_t i = 0; i < model.images.size(); ++i)
    if (model.images[i].id == key_id) key = static_cast<int>(i);
  if (key < 0)
    throw std::invalid_argument("'" + key_id +
                                "' is not registered in the model");
  const Covisibility covisibility(model);
  const std::vector<int> neighbours =
      choose_neighbours(covisibility, key, options);
  if (neighbours.empty())
    throw std::invalid_argument("'" + key_id +
                                "' shares too few points with any other view");
  const DenseView key_view =
      load_view(model, key, images, covisibility, options.long_side);
  std::vector<DenseView> views;
  for (int n : neighbours)
    views.push_back(
        load_view(model, n, images, covisibility, options.long_side));
  std::vector<const DenseView*> pointers;
  for (const DenseView& v : views) pointers.push_back(&v);
  return sweep_planes(key_view, pointers, options.sweep);
}

cv::Mat load_undistorted(const Model& model, const std::string& id,
                         const ImageSource& images, int long_side,
                         Eigen::Matrix3d* K) {
  for (size_t i = 0; i < model.images.size(); ++i) {
    if (model.images[i].id != id) continue;
    const Covisibility covisibility(model);
    DenseView view =
        load_view(model, static_cast<int>(i), images, covisibility, long_side);
    if (K) *K = view.K;
    return view.bgr;
  }
  throw std::invalid_argument("'" + id + "' is not registered in the model");
}

}  // namespace arscout::engine
