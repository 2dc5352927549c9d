#include "site_job.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <iomanip>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "arscout/db/path.h"
#include "arscout/db/store.h"
#include "arscout/documents/capture.h"
#include "arscout/documents/engine_state.h"
#include "arscout/engine/ply.h"
#include "arscout/util/clock.h"
#include "capture_document.h"
#include "state_parts.h"

namespace arscout::engine::service {
namespace {

using Clock = std::chrono::steady_clock;

using util::seconds_since;

std::string site_path(const std::string& site, const std::string& leaf) {
  return "/sites/" + site + "/" + leaf;
}

}  // namespace

SiteJob::SiteJob(std::string id, db::Store& store, const WorkerOptions& options,
                 CapturePreparer* preparer)
    : id_(std::move(id)),
      store_(store),
      options_(options),
      preparer_(preparer),
      feature_writer_(store) {}

SiteJob::~SiteJob() = default;

int SiteJob::registered() const {
  return sparse_ ? sparse_->registered_count() : 0;
}

void SiteJob::clear_pending() {
  pending_statuses_.clear();
  pending_depth_maps_.clear();
  pending_removed_maps_.clear();
  pending_engine_written_ = pending_state_written_ = pending_unsaved_ = false;
}

double SiteJob::seconds_state_unsaved() const {
  return state_unsaved() ? seconds_since(unsaved_since_) : 0;
}

double SiteJob::seconds_since_commit() const {
  return seconds_since(last_commit_);
}

void SiteJob::reset() {
  loaded_ = false;
  state_unsaved_ = false;
  dense_in_flight_ = false;
  dense_finishing_ = false;
  sparse_.reset();
  dense_.reset();
  statuses_.clear();
  depth_maps_.clear();
  feature_writes_.clear();
  std::lock_guard lock(images_mutex_);
  images_.clear();
}

std::string SiteJob::image_bytes(const std::string& capture) {
  std::string sha;
  {
    std::lock_guard lock(images_mutex_);
    auto it = images_.find(capture);
    if (it != images_.end()) sha = it->second;
  }
  if (sha.empty()) {
    sha = capture_image_sha(store_, capture);
    std::lock_guard lock(images_mutex_);
    images_.emplace(capture, sha);
  }
  return store_.get_blob(sha);
}

// The dense options of this site's lane. A dense lane publishes after every
// few sweeps, and sweeps a new view before re-fusing old maps that moved,
// so each photo's part of the cloud shows sooner; deterministic runs keep
// the options as given (their dense phase settles every update).
DenseOptions SiteJob::lane_dense_options() const {
  constexpr int kLaneSweepBudget = 2;
  constexpr int kLaneRefuseBudgetSweeping = 2;
  constexpr int kLaneCatchUpBacklog = 2;
  DenseOptions options = options_.dense_options;
  if (options_.reconstruction.deterministic) return options;
  if (options.sweep_budget == 0) options.sweep_budget = kLaneSweepBudget;
  if (options.refuse_budget_sweeping < 0)
    options.refuse_budget_sweeping = kLaneRefuseBudgetSweeping;
  if (options.catch_up_backlog < 0)
    options.catch_up_backlog = kLaneCatchUpBacklog;
  return options;
}

void SiteJob::restore() {
  sparse_ = std::make_unique<Reconstruction>(options_.reconstruction);
  ++generation_;
  dense_.reset();
  if (options_.dense)
    dense_ = std::make_shared<DenseReconstruction>(lane_dense_options());
  dense_tiles_.clear();
  mesh_tiles_.clear();
  mesh_cursor_ = {};  // a restored cloud: every column looked at again
  dense_points_ = 0;
  dense_views_.clear();
  if (auto model = store_.get(site_path(id_, "model"))) {
    model_version_ = model->version;
    const documents::ModelDocument doc =
        documents::model_from_json(model->attrs);
    dense_tiles_ = dense_tiles_from_json(
        doc.dense_tiles.is_null() ? Json::array() : doc.dense_tiles);
    mesh_tiles_ = mesh_tiles_of(*model);
    dense_points_ = doc.statistics.dense_points;
    for (const documents::ModelImageEntry& image : doc.images)
      if (image.dense.value_or(false)) dense_views_.insert(image.id);
  }
  pending_dense_tiles_ = dense_tiles_;
  pending_mesh_tiles_ = mesh_tiles_;
  pending_mesh_cursor_ = mesh_cursor_;
  auto state = store_.get(site_path(id_, "engine"));
  engine_version_ = state ? state->version : 0;
  const documents::EngineState header =
      state ? documents::engine_state_from_json(state->attrs)
            : documents::EngineState{};
  through_seq_ = header.through_seq;
  // A crash between the two phases left the dense cloud behind.
  dense_due_ = options_.dense && header.dense_due;
  dense_in_flight_ = false;
  dense_finishing_ = false;
  dense_added_.clear();
  dense_withdrawn_.clear();
  features_.clear();
  pending_features_.clear();
  pending_removed_features_.clear();
  if (state && !state->blobs.empty()) {
    // Of the state read above: a commit in between changes its version,
    // and this job's next write, fenced on that version, fails and retries.
    if (auto restored = load_site_reconstruction(
            store_, id_, options_.reconstruction, &features_))
      *sparse_ = std::move(*restored);
    for (const auto& [capture, status] : header.statuses)
      statuses_[capture] = status;
  }
  if (dense_) {
    std::vector<std::string> maps;
    for (const db::Document& doc :
         store_.list_children(site_path(id_, "depth"))) {
      if (!doc.blobs.count("map")) continue;
      maps.push_back(store_.get_blob(doc.blobs.at("map")));
      depth_maps_.insert(std::string(db::leaf_name(doc.path)));
    }
    if (!maps.empty()) {
      dense_->restore_depth_maps(
          maps, sparse_->model(),
          [this](const std::string& c) { return image_bytes(c); });
    }
  }
  loaded_ = true;
}

void SiteJob::add(const std::string& capture, bool more_follow,
                  IncrementReport* report) {
  for (const CaptureState& c : sparse_->captures())
    if (c.id == capture) return;  // delivered again: already in the state
  AddResult result;
  try {
    // Prepared ahead when a preparer holds it (capture_preparer.h).
    std::optional<CapturePreparer::Prepared> ready;
    if (preparer_) ready = preparer_->take(capture);
    CaptureInput input =
        ready ? capture_input(store_, capture, std::move(ready->image_bytes))
              : capture_input(store_, capture, image_bytes(capture));
    input.more_follow = more_follow;
    result = ready ? sparse_->add_capture(input, ready->photo)
                   : sparse_->add_capture(input);
  } catch (const std::invalid_argument& e) {
    // A photo the engine cannot use is rejected, not retried forever.
    pending_statuses_[capture] =
        to_string(CaptureStatus::kRejected) + ("\n" + std::string(e.what()));
    return;
  }
  report->added.push_back(capture);
  const StageTimings& t = result.timings;
  StageTimings& s = report->sparse;
  s.decode_s += t.decode_s;
  s.undistort_s += t.undistort_s;
  s.features_s += t.features_s;
  s.matching_s += t.matching_s;
  s.pose_s += t.pose_s;
  s.triangulation_s += t.triangulation_s;
  s.bundle_adjustment_s += t.bundle_adjustment_s;
  s.total_s += t.total_s;
}

namespace {
// Where an increment's time went, for the progress log: the stages that
// grow with the site (matching, the adjustments) and the rest.
std::string stage_split(const StageTimings& t) {
  const auto ms = [](double s) {
    return std::to_string(std::lround(s * 1000));
  };
  const double rest = t.total_s - t.matching_s - t.bundle_adjustment_s;
  return ": matching " + ms(t.matching_s) + ", adjustment " +
         ms(t.bundle_adjustment_s) + ", the rest " + ms(rest);
}
}  // namespace

Increment SiteJob::run(const std::vector<Work>& work,
                       std::int64_t settled_through, bool save_state) {
  const auto start = Clock::now();
  if (!loaded_) restore();
  clear_pending();
  IncrementReport report;
  pending_through_seq_ = std::max(through_seq_, settled_through);
  Increment increment;
  for (auto w = work.begin(); w != work.end(); ++w) {
    increment.settled.push_back(w->capture);
    if (w->kind == Work::Kind::kAdd) {
      const bool more_follow = std::any_of(
          w + 1, work.end(),
          [](const Work& later) { return later.kind == Work::Kind::kAdd; });
      add(w->capture, more_follow, &report);
    } else if (sparse_->remove_capture(w->capture)) {
      report.withdrawn.push_back(w->capture);
    }
  }
  start_feature_writes(report);
  const Model model = sparse_->model();
  const bool changed = !report.added.empty() || !report.withdrawn.empty();
  if (dense_ && changed && (!model.images.empty() || !depth_maps_.empty())) {
    dense_due_ = true;
    for (const std::string& c : report.added) dense_added_.push_back(c);
    for (const std::string& c : report.withdrawn) dense_withdrawn_.push_back(c);
  }
  report.dense_points = dense_points_;
  report.total_s = seconds_since(start);

  const auto writes_start = Clock::now();
  increment.footprint = registered_footprint(model);
  std::vector<db::WriteOp> ops;
  const std::vector<CaptureState> captures = sparse_->captures();
  add_status_ops(captures, &ops);
  const bool publish_model =
      changed && (!model.images.empty() || model_version_ > 0);
  if (publish_model) {
    ops.push_back(model_op(model, captures, report));
    increment.model_written = true;
  }
  const size_t state_bytes =
      save_state ? add_state_ops(model, report.added, &ops) : 0;
  increment.state_written = save_state;
  pending_unsaved_ = !save_state;
  const double writes_s = seconds_since(writes_start);

  pending_model_version_ = model_version_ + (publish_model ? 1 : 0);
  std::ostringstream summary;
  summary << "site " << id_ << ": +" << report.added.size() << " capture"
          << (report.added.size() == 1 ? "" : "s");
  if (!report.withdrawn.empty()) summary << ", -" << report.withdrawn.size();
  summary << ", " << model.images.size() << " registered"
          << (model.geo_registered ? " (ENU)" : " (local frame)") << ", "
          << model.points.size() << " points";
  if (publish_model) summary << ", model v" << pending_model_version_;
  if (dense_due_) summary << ", dense to follow";
  summary << " (" << static_cast<int>(report.total_s * 1000) << " ms"
          << stage_split(report.sparse) << "; its writes";
  if (save_state)
    summary << ", with a state of " << std::fixed << std::setprecision(1)
            << state_bytes / 1e6 << " MB,";
  else
    summary << " (the state unsaved)";
  summary << " in " << static_cast<int>(writes_s * 1000) << " ms)";
  increment.summary = summary.str();
  increment.ops = std::move(ops);
  return increment;
}

// The capture statuses that changed since they were last published. A
// status is kept as "status\nreason"; a registered capture has no reason,
// and "#N" in its place names its component.
void SiteJob::add_status_ops(const std::vector<CaptureState>& captures,
                             std::vector<db::WriteOp>* ops) {
  for (const CaptureState& c : captures) {
    const std::string status =
        to_string(documents::capture_document_status(c.status));
    const std::string key =
        status + "\n" +
        (c.component >= 0 ? "#" + std::to_string(c.component) : c.reason);
    if (statuses_.count(c.id) && statuses_.at(c.id) == key) continue;
    pending_statuses_[c.id] = key;
  }
  for (const auto& [capture, key] : pending_statuses_) {
    const size_t cut = key.find('\n');
    std::string reason = key.substr(cut + 1);
    std::optional<int> component;
    if (!reason.empty() && reason[0] == '#') {
      component = std::atoi(reason.c_str() + 1);
      reason.clear();
    }
    ops->push_back(db::WriteOp::patch(
        "/captures/" + capture,
        documents::status_patch(
            documents::parse_capture_status(key.substr(0, cut)), reason, id_,
            component)));
  }
}

// The engine state, so that a restart needs no recomputation: each
// capture's features once, under features/ (fixed once extracted, most of
// the bytes), and the rest in content-defined parts (state_parts.h), of
// which the store writes only the new ones.
size_t SiteJob::add_state_ops(const Model& model,
                              const std::vector<std::string>& added,
                              std::vector<db::WriteOp>* ops) {
  pending_features_.clear();
  pending_removed_features_ = features_;
  for (const std::string& capture : sparse_->captures_with_features()) {
    pending_removed_features_.erase(capture);
    if (features_.count(capture) &&
        std::find(added.begin(), added.end(), capture) == added.end())
      continue;
    db::WriteOp op =
        db::WriteOp::put(site_path(id_, "features/" + capture),
                         "capture-features", Json{{"capture", capture}});
    op.blobs = db::BlobRefs{{"features", features_blob(capture)}};
    ops->push_back(std::move(op));
    pending_features_.insert(capture);
  }
  for (const std::string& capture : pending_removed_features_)
    ops->push_back(db::WriteOp::remove(site_path(id_, "features/" + capture)));
  documents::EngineState header;
  for (const auto& [c, s] : statuses_) header.statuses[c] = s;
  for (const auto& [c, s] : pending_statuses_) header.statuses[c] = s;
  header.registered = static_cast<std::int64_t>(model.images.size());
  header.through_seq = pending_through_seq_;
  header.dense_due = dense_due_ || dense_in_flight_;
  db::WriteOp state =
      db::WriteOp::put(site_path(id_, "engine"), "engine-state",
                       documents::to_json(header), engine_version_);
  const std::string bytes = sparse_->serialize(/*features_apart=*/true);
  const std::vector<std::string_view> parts = cut_state_parts(bytes);
  const std::vector<std::string> shas = store_.put_blobs(parts);
  db::BlobRefs refs;
  for (size_t i = 0; i < parts.size(); ++i) refs[state_part_name(i)] = shas[i];
  state.blobs = std::move(refs);
  ops->push_back(std::move(state));
  pending_engine_written_ = pending_state_written_ = true;
  return bytes.size();
}

void SiteJob::start_feature_writes(const IncrementReport& report) {
  for (const std::string& capture : report.withdrawn)
    feature_writes_.erase(capture);
  for (const std::string& capture : report.added) {
    if (sparse_->has_features(capture))
      feature_writes_[capture] =
          feature_writer_.put(sparse_->capture_features(capture));
  }
}

std::string SiteJob::features_blob(const std::string& capture) {
  auto queued = feature_writes_.find(capture);
  if (queued != feature_writes_.end()) {
    std::shared_future<std::string> sha = queued->second;
    feature_writes_.erase(queued);
    try {
      return sha.get();
    } catch (const std::exception&) {
      // Written again below: the store's error, if it persists, is this
      // save's to report.
    }
  }
  return store_.put_blob(sparse_->capture_features(capture));
}

Increment SiteJob::save_state() {
  Increment increment;
  if (!state_unsaved()) return increment;
  clear_pending();
  pending_through_seq_ = through_seq_;
  const auto start = Clock::now();
  const Model model = sparse_->model();
  increment.footprint = registered_footprint(model);
  const size_t bytes = add_state_ops(model, {}, &increment.ops);
  increment.state_written = true;
  pending_model_version_ = model_version_;
  std::ostringstream summary;
  summary << "site " << id_ << ": engine state saved (" << std::fixed
          << std::setprecision(1) << bytes / 1e6 << " MB, "
          << static_cast<int>(seconds_since(start) * 1000) << " ms)";
  increment.summary = summary.str();
  return increment;
}

Increment SiteJob::absorb(SiteJob& other) {
  const auto start = Clock::now();
  if (!loaded_) restore();
  if (!other.loaded_) other.restore();
  clear_pending();
  pending_through_seq_ = std::max(through_seq_, other.through_seq_);
  IncrementReport report;
  for (const CaptureState& c : other.sparse_->captures())
    report.added.push_back(c.id);
  const AbsorbResult absorbed = sparse_->absorb(std::move(*other.sparse_));
  {
    std::lock_guard lock(other.images_mutex_);
    std::lock_guard mine(images_mutex_);
    images_.insert(other.images_.begin(), other.images_.end());
  }
  const Model model = sparse_->model();
  if (dense_) {
    // Its depth maps are in its own frame: its views are swept again here.
    dense_due_ = true;
    for (const std::string& c : report.added) dense_added_.push_back(c);
  }
  report.dense_points = dense_points_;
  report.total_s = seconds_since(start);
  Increment increment;
  increment.footprint = registered_footprint(model);
  const std::vector<CaptureState> captures = sparse_->captures();
  add_status_ops(captures, &increment.ops);
  increment.ops.push_back(model_op(model, captures, report));
  increment.model_written = true;
  add_state_ops(model, report.added, &increment.ops);
  increment.state_written = true;
  other.add_departure_ops(&increment.ops);
  pending_model_version_ = model_version_ + 1;
  std::ostringstream summary;
  summary << "site " << id_ << ": took in site " << other.id_ << " ("
          << absorbed.captures << " captures, " << absorbed.pairs_across
          << " pairs across, " << absorbed.components_merged
          << " components merged), " << model.images.size() << " registered in "
          << model.components.size() << " component(s), model v"
          << pending_model_version_ << " ("
          << static_cast<int>(seconds_since(start) * 1000) << " ms)";
  increment.summary = summary.str();
  other.reset();
  return increment;
}

void SiteJob::add_departure_ops(std::vector<db::WriteOp>* ops) const {
  for (const char* leaf : {"model", "engine"}) {
    if (store_.get(site_path(id_, leaf)))
      ops->push_back(db::WriteOp::remove(site_path(id_, leaf)));
  }
  for (const char* folder : {"features", "depth", "dense"}) {
    for (const db::Document& doc : store_.list_children(site_path(id_, folder)))
      ops->push_back(db::WriteOp::remove(doc.path));
  }
}

bool SiteJob::refinement_due() const {
  return loaded_ && sparse_ && sparse_->refinement_due();
}

bool SiteJob::refinement_urgent() const {
  return loaded_ && sparse_ && sparse_->refinement_urgent();
}

Increment SiteJob::run_refine(const std::function<bool()>& stop) {
  Increment increment;
  if (!refinement_due()) return increment;
  clear_pending();
  pending_through_seq_ = through_seq_;
  const RefineResult refined = sparse_->refine(stop);
  if (!refined.ran) return increment;
  // The depth maps follow the moved cameras in the next dense phase, whose
  // report names the waiting captures registered here (Reconstruction::
  // refine) among those it adds.
  if (dense_) {
    dense_due_ = true;
    for (const std::string& c : refined.registered) dense_added_.push_back(c);
  }
  const Model model = sparse_->model();
  increment.footprint = registered_footprint(model);
  IncrementReport report;
  report.dense_points = dense_points_;
  report.total_s = refined.seconds;
  const std::vector<CaptureState> captures = sparse_->captures();
  add_status_ops(captures, &increment.ops);
  increment.ops.push_back(model_op(model, captures, report));
  add_state_ops(model, {}, &increment.ops);
  increment.state_written = true;
  increment.model_written = true;
  increment.refine_again =
      (!refined.registered.empty() || refined.components_merged > 0) &&
      sparse_->refinement_due();
  pending_model_version_ = model_version_ + 1;
  std::ostringstream summary;
  summary << "site " << id_ << ": ";
  if (refined.components_merged > 0) {
    summary << "merged " << refined.components_merged << " components";
  } else if (refined.registered.empty()) {
    summary << "global refinement of " << refined.images << " key views, "
            << refined.iterations << " iterations, cameras moved up to "
            << refined.largest_move << " (keypoints " << refined.pixel_sigma
            << " px), " << refined.tracks_joined << " matches joined, "
            << refined.corners_matched << " weak corners matched, "
            << refined.loose_links << " loose-pair matches linked ("
            << refined.strained_links << " strained)";
  } else {
    summary << "registered " << refined.registered.size()
            << " waiting captures";
  }
  summary << (refined.converged ? "" : " (gave way to new work)") << ", model v"
          << pending_model_version_ << " ("
          << static_cast<int>(refined.seconds * 1000) << " ms)";
  increment.summary = summary.str();
  return increment;
}

Increment SiteJob::run_dense() {
  std::optional<DenseTask> task = begin_dense();
  if (!task) return {};
  task->settle = true;
  compute_dense(*task);
  return finish_dense(*task);
}

std::optional<DenseTask> SiteJob::begin_dense() {
  if (!loaded_) restore();
  if (!dense_ || !dense_due_ || dense_in_flight_) return std::nullopt;
  DenseTask task;
  task.dense = dense_;
  task.generation = generation_;
  task.published = dense_tiles_;
  task.published_mesh = mesh_tiles_;
  task.mesh_cursor = mesh_cursor_;
  task.model = sparse_->model();
  task.added = std::move(dense_added_);
  task.withdrawn = std::move(dense_withdrawn_);
  dense_added_.clear();
  dense_withdrawn_.clear();
  dense_due_ = false;
  dense_in_flight_ = true;
  return task;
}

void SiteJob::compute_dense(DenseTask& task) {
  const auto start = Clock::now();
  DenseReconstruction& dense = *task.dense;
  dense.set_parallel_while(task.parallel);
  const ImageSource images = [this](const std::string& c) {
    return image_bytes(c);
  };
  task.update = task.settle ? update_until_settled(dense, task.model, images)
                            : dense.update(task.model, images);
  // The question is this phase's (it reads the worker's queue of now).
  dense.set_parallel_while(nullptr);
  for (const std::string& map : task.update.new_depth_maps)
    task.map_blobs[map] = store_.put_blob(dense.serialize_depth_map(map));
  task.kept_maps = dense.depth_map_ids();
  task.views.insert(task.kept_maps.begin(), task.kept_maps.end());
  const std::vector<std::string> covered = dense.covered_ids();
  task.views.insert(covered.begin(), covered.end());
  task.tiles_held = tiles_wait(task.update);
  const bool meshing = options_.mesh && dense.voxel_size() > 0;
  const auto put = [this](const std::string& bytes) {
    return store_.put_blob(bytes);
  };
  if (!task.tiles_held) {
    task.tiles = store_dense_tiles(
        dense.points(), dense_tile_size(dense.voxel_size()), task.published,
        put, kIsolatedRadiusVoxels * dense.voxel_size(),
        dense.voxel_size() > 0 ? kIsolatedMinNeighbours : 0);
    tiles_stored_at_ = Clock::now();
  }
  // The surface in every phase, the tiles held or not: its budget keeps
  // each phase short, so it must not wait for the tiles' interval.
  if (meshing) {
    MeshBuildOptions mesh_options;
    mesh_options.budget_seconds =
        task.settle || options_.reconstruction.deterministic
            ? 0
            : options_.mesh_budget_seconds;
    // A cloud rebuilt from all its maps has moved as a whole (a new frame
    // or voxel): a surface made before it would be drawn out of place
    // until made again, so the mesh starts over, the new tiles first.
    // It reads only the columns near the cloud's changes since the
    // published surface was made (MeshCursor), not the whole cloud.
    const std::uint64_t now = dense.mark_cloud();
    const std::vector<MeshTileEntry> none;
    task.mesh =
        update_mesh_tiles(DenseMeshCloud(dense), now, dense.voxel_size(),
                          task.update.refused ? none : task.published_mesh,
                          task.update.refused ? MeshCursor{} : task.mesh_cursor,
                          dense.key_views(), put, mesh_options);
  }
  task.voxel_size = dense.voxel_size();
  task.seconds = seconds_since(start);
}

// Only the dense lane reads and sets tiles_stored_at_ (one phase at a time).
bool SiteJob::tiles_wait(const DenseUpdate& update) const {
  const bool more_to_come =
      update.deferred_maps > 0 || update.deferred_views > 0;
  return more_to_come && options_.dense_tile_interval.count() > 0 &&
         !options_.reconstruction.deterministic && tiles_stored_at_ &&
         Clock::now() - *tiles_stored_at_ < options_.dense_tile_interval;
}

Increment SiteJob::finish_dense(DenseTask& task) {
  Increment increment;
  if (!loaded_ || task.generation != generation_) return increment;
  clear_pending();
  pending_through_seq_ = through_seq_;
  std::vector<db::WriteOp> ops;
  for (const auto& [map, sha] : task.map_blobs) {
    db::WriteOp op = db::WriteOp::put(site_path(id_, "depth/" + map),
                                      "depth-map", Json{{"capture", map}});
    op.blobs = db::BlobRefs{{"map", sha}};
    ops.push_back(std::move(op));
    pending_depth_maps_.insert(map);
  }
  for (const std::string& map : depth_maps_) {
    if (std::find(task.kept_maps.begin(), task.kept_maps.end(), map) !=
        task.kept_maps.end())
      continue;
    ops.push_back(db::WriteOp::remove(site_path(id_, "depth/" + map)));
    pending_removed_maps_.insert(map);
  }
  if (!task.tiles_held) add_tile_ops(task.tiles, &ops);
  if (task.mesh) add_mesh_tile_ops(task.mesh->tiles, &ops);
  IncrementReport report;
  report.added = task.added;
  report.withdrawn = task.withdrawn;
  report.dense = task.update;
  report.dense_points = task.tiles_held ? dense_points_ : task.update.points;
  report.total_s = task.seconds;
  // Moved maps or views left for later: the lane runs again, and the
  // cloud is published as pending until then.
  if (task.update.deferred_maps > 0 || task.update.deferred_views > 0 ||
      (task.mesh && task.mesh->left > 0))
    dense_due_ = true;
  // The sparse model of now: the sparse lane may have moved on meanwhile.
  const Model model = sparse_->model();
  const bool publish_model = !model.images.empty() || model_version_ > 0;
  if (publish_model) {
    pending_dense_points_ = report.dense_points;
    ops.push_back(model_op(model, sparse_->captures(), report,
                           task.tiles_held ? nullptr : &task.tiles,
                           task.tiles_held ? nullptr : &task.views,
                           task.mesh ? &*task.mesh : nullptr));
    increment.model_written = true;
  }
  // Fenced like the sparse phase: a patch on the version this job wrote.
  // A site whose state was never saved yet has no document to patch: its
  // first state write records the cloud's state (EngineState::dense_due).
  if (engine_version_ > 0) {
    ops.push_back(db::WriteOp::patch(site_path(id_, "engine"),
                                     documents::dense_due_patch(dense_due_),
                                     engine_version_));
    pending_engine_written_ = true;
  }
  pending_model_version_ = model_version_ + (publish_model ? 1 : 0);
  increment.summary = dense_summary(task, publish_model);
  increment.ops = std::move(ops);
  dense_finishing_ = true;
  return increment;
}

// The tiles that changed since the published cloud, and those gone.
void SiteJob::add_tile_ops(const DenseTiles& tiles,
                           std::vector<db::WriteOp>* ops) const {
  for (const auto& [name, tile] : tiles) {
    const auto was = dense_tiles_.find(name);
    if (was != dense_tiles_.end() && was->second.blob == tile.blob) continue;
    db::WriteOp op =
        db::WriteOp::put(site_path(id_, "dense/" + name), "dense-tile",
                         Json{{"tile", name}, {"points", tile.points}});
    op.blobs = db::BlobRefs{{"points", tile.blob}};
    ops->push_back(std::move(op));
  }
  for (const auto& [name, tile] : dense_tiles_)
    if (!tiles.count(name))
      ops->push_back(db::WriteOp::remove(site_path(id_, "dense/" + name)));
}

// The mesh tiles that changed since the published surface, each a document
// whose blob references keep its levels' GLBs from the collector (the
// model's mesh_tiles only names them), and those gone.
void SiteJob::add_mesh_tile_ops(const std::vector<MeshTileEntry>& tiles,
                                std::vector<db::WriteOp>* ops) const {
  std::map<std::string, const MeshTileEntry*> before;
  for (const MeshTileEntry& tile : mesh_tiles_) before[tile.tile] = &tile;
  std::set<std::string> now;
  for (const MeshTileEntry& tile : tiles) {
    now.insert(tile.tile);
    const auto was = before.find(tile.tile);
    if (was != before.end() && was->second->hash == tile.hash &&
        was->second->cell == tile.cell)
      continue;
    db::BlobRefs blobs;
    for (std::size_t l = 0; l < tile.levels.size(); ++l)
      blobs["level-" + std::to_string(l)] = tile.levels[l].blob;
    db::WriteOp op = db::WriteOp::put(
        site_path(id_, "mesh/" + tile.tile), "mesh-tile",
        Json{{"tile", tile.tile}, {"levels", tile.levels.size()}});
    op.blobs = std::move(blobs);
    ops->push_back(std::move(op));
  }
  for (const auto& [name, tile] : before)
    if (!now.count(name))
      ops->push_back(db::WriteOp::remove(site_path(id_, "mesh/" + name)));
}

std::string SiteJob::dense_summary(const DenseTask& task,
                                   bool model_published) const {
  const DenseUpdate& update = task.update;
  std::ostringstream summary;
  summary << "site " << id_ << ": dense " << update.points << " points (voxel "
          << task.voxel_size << (update.refused ? ", re-fused" : "");
  if (!update.refused && update.refused_maps > 0)
    summary << ", " << update.refused_maps << " moved map"
            << (update.refused_maps == 1 ? "" : "s") << " re-fused";
  if (update.deferred_maps > 0)
    summary << ", " << update.deferred_maps << " left for later";
  if (update.deferred_views > 0)
    summary << ", " << update.deferred_views << " view"
            << (update.deferred_views == 1 ? "" : "s") << " to sweep next";
  summary << ", " << update.new_depth_maps.size() << " new depth map"
          << (update.new_depth_maps.size() == 1 ? "" : "s");
  if (update.caught_up_maps > 0)
    summary << " (" << update.caught_up_maps << " coarse, catching up)";
  if (!update.covered.empty())
    summary << ", " << update.covered.size() << " covered by the key views";
  summary << ")";
  if (task.mesh)
    summary << ", mesh " << task.mesh->triangles << " triangles ("
            << task.mesh->remade << " tiles made, " << task.mesh->left
            << " left, " << task.mesh->left_new << " of them new, "
            << task.mesh->looked_at << " columns read, "
            << static_cast<int>(task.mesh->seconds * 1000) << " ms)";
  if (model_published) summary << ", model v" << pending_model_version_;
  summary << " (" << static_cast<int>(task.seconds * 1000) << " ms)";
  return summary.str();
}

db::WriteOp SiteJob::model_op(const Model& model,
                              const std::vector<CaptureState>& captures,
                              const IncrementReport& report,
                              const DenseTiles* new_cloud,
                              const std::set<std::string>* new_views,
                              const MeshBuild* new_mesh) {
  if (dense_) pending_dense_views_ = new_views ? *new_views : dense_views_;
  documents::ModelDocument doc = model_document(
      id_, model, captures, report, dense_ ? &pending_dense_views_ : nullptr);
  // Current: the cloud follows every change of the model published with it.
  const bool behind = dense_due_ || (dense_in_flight_ && !new_cloud);
  doc.dense_state = !dense_ ? "off" : (behind ? "pending" : "current");
  if (dense_) {
    // The sparse phase republishes the last dense cloud; the dense phase
    // replaces it.
    pending_dense_tiles_ = new_cloud ? *new_cloud : dense_tiles_;
    doc.dense_tiles = dense_tiles_json(pending_dense_tiles_);
    if (new_mesh) {
      pending_mesh_tiles_ = new_mesh->tiles;
      pending_mesh_cursor_ = new_mesh->cursor;
    }
    if (!pending_mesh_tiles_.empty())
      doc.mesh_tiles = mesh_tiles_json(pending_mesh_tiles_);
  }
  db::WriteOp op = db::WriteOp::put(site_path(id_, "model"), "model",
                                    documents::to_json(doc));
  op.blobs = db::BlobRefs{{"sparse", store_.put_blob(sparse_ply(model))}};
  return op;
}

void SiteJob::committed() {
  last_commit_ = Clock::now();
  if (dense_finishing_) {
    dense_finishing_ = false;
    dense_in_flight_ = false;
    dense_points_ = pending_dense_points_;
    dense_views_ = pending_dense_views_;
  }
  dense_tiles_ = pending_dense_tiles_;
  mesh_tiles_ = pending_mesh_tiles_;
  mesh_cursor_ = pending_mesh_cursor_;
  for (const auto& [c, s] : pending_statuses_) statuses_[c] = s;
  for (const std::string& m : pending_depth_maps_) depth_maps_.insert(m);
  for (const std::string& m : pending_removed_maps_) depth_maps_.erase(m);
  for (const std::string& c : pending_features_) features_.insert(c);
  for (const std::string& c : pending_removed_features_) features_.erase(c);
  pending_features_.clear();
  pending_removed_features_.clear();
  model_version_ = pending_model_version_;
  through_seq_ = pending_through_seq_;
  if (pending_engine_written_) ++engine_version_;
  if (pending_state_written_) {
    state_unsaved_ = false;
  } else if (pending_unsaved_ && !state_unsaved_) {
    state_unsaved_ = true;
    unsaved_since_ = Clock::now();
  }
  pending_engine_written_ = pending_state_written_ = pending_unsaved_ = false;
  pending_statuses_.clear();
  pending_depth_maps_.clear();
}

}  // namespace arscout::engine::service
