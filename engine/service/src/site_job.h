// One site's engine state and its increments: the captures placed in the
// site are added to its Reconstruction (and the dense cloud grown) in
// batches, and each batch becomes the writes that publish it. The state is
// restored from the store the first time a job runs, so a restarted worker
// continues where the last committed increment left off.
//
// Two lanes may work on one site at once: the sparse lane (run, run_refine)
// and the dense lane (begin_dense, compute_dense, finish_dense). Every call
// except compute_dense must hold publication(), and so must the commit of
// the writes it returns and committed(): the site's model versions and its
// fenced engine-state writes then follow one order.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "arscout/db/document.h"
#include "arscout/engine/service.h"
#include "blob_writer.h"
#include "capture_preparer.h"
#include "dense_tiles.h"
#include "mesh_builder.h"
#include "model_document.h"
#include "site_directory.h"

namespace arscout::db {
class Store;
}

namespace arscout::engine::service {

struct Work {
  // kMerge: the site named by `capture` grew into this one (the worker
  // runs it, SiteJob::absorb; run() takes the others).
  enum class Kind { kAdd, kWithdraw, kMerge };
  Kind kind = Kind::kAdd;
  std::string capture;
  std::int64_t seq = 0;  // of the change that asked for it
  std::string scout;     // who sent the capture (fair turns between scouts)
};

// A dense phase out of the publication order: begin_dense() takes the
// model and what changed; compute_dense() sweeps, fuses and stores the
// blobs (the long part, while the sparse lane goes on); finish_dense()
// publishes the cloud with the sparse model of that moment.
struct DenseTask {
  std::shared_ptr<DenseReconstruction> dense;
  std::uint64_t generation = 0;  // of the job state it was taken from
  Model model;
  std::vector<std::string> added, withdrawn;
  // Whether to sweep over OpenCV's threads now, asked as the work goes
  // (DenseReconstruction::set_parallel_while): the worker says no while the
  // site's sparse lane is busy. Empty: parallel throughout.
  std::function<bool()> parallel;
  // Re-fuse every moved map before publishing (update_until_settled): the
  // one-step run_dense() of deterministic runs. A lane instead leaves the
  // rest to its next phase (DenseOptions::refuse_budget).
  bool settle = false;
  // Filled in by compute_dense().
  DenseUpdate update;
  std::map<std::string, std::string> map_blobs;  // new depth map -> sha
  std::vector<std::string> kept_maps;
  std::set<std::string> views;  // the cloud covers them (model_attrs)
  DenseTiles published;         // the tiles as published when it began
  DenseTiles tiles;
  // The tiles were not stored (WorkerOptions::dense_tile_interval): the
  // model keeps the published cloud, and a later phase stores the change.
  bool tiles_held = false;
  // The surface (WorkerOptions::mesh) as published when it began, and as
  // made after the tiles; empty when not made this time.
  std::vector<MeshTileEntry> published_mesh;
  MeshCursor mesh_cursor;  // the one published_mesh was made with
  std::optional<MeshBuild> mesh;
  double voxel_size = 0;
  double seconds = 0;
};

struct Increment {
  std::vector<db::WriteOp> ops;  // blobs they name are stored already
  std::string summary;           // one line for the progress log
  bool model_written = false;
  // A refinement that registered waiting captures: the global adjustment
  // they make due is the next call's.
  bool refine_again = false;
  double seconds = 0;  // how long it took to make, set by the worker
  // Where the site's registered cameras are after it, and the captures it
  // processed (registered or not): the site's footprint follows them
  // (SiteDirectory::follow).
  Footprint footprint;
  std::vector<std::string> settled;
  // Whether its writes hold the engine state (all of the job's work so
  // far); a run() that leaves it out leaves the state unsaved.
  bool state_written = false;
};

class SiteJob {
 public:
  // `preparer`, when given, prepares this site's photos ahead of its
  // increments (it outlives the job).
  SiteJob(std::string id, db::Store& store, const WorkerOptions& options,
          CapturePreparer* preparer = nullptr);
  ~SiteJob();

  const std::string& id() const { return id_; }

  // Applies `work` to the in-memory state and returns the writes that
  // publish it (without the site document and the checkpoint, which the
  // worker adds). `settled_through`: every change of this site at or below
  // that seq is in `work` or was folded before (the worker may take work
  // out of order, for fairness between scouts); the state records it
  // (attrs.through_seq), and another worker settles its deferred work by
  // it. Throws db::StoreError when the store fails; the caller
  // then calls reset() and retries later. The writes are fenced: the engine
  // state document is written on the condition that it is still the
  // version this job restored or last wrote, so a worker that lost the
  // site's lease while it ran cannot overwrite the new holder's work (its
  // batch fails with a conflict).
  //
  // With `save_state` false the writes leave the engine state out (its
  // serialization grows with the site, ~90 KB a photo, and sits on the
  // latency path): the model and statuses are published, and the state
  // stays unsaved until a later call writes it (Increment::state_written).
  // Work whose state is unsaved must stay in flight for the worker: a
  // restart restores the last saved state and redoes it.
  Increment run(const std::vector<Work>& work, std::int64_t settled_through,
                bool save_state = true);
  // The writes of the engine state alone, for work run() left unsaved;
  // none when nothing is unsaved.
  Increment save_state();
  // Work was committed since the state was last written, and for how long.
  bool state_unsaved() const { return loaded_ && state_unsaved_; }
  double seconds_state_unsaved() const;
  // Seconds since the last increment of this site was committed (since
  // the job was made, before any).
  double seconds_since_commit() const;
  // True when the last run() changed the model and the dense cloud has yet
  // to follow (also after a restart that found it behind).
  bool dense_due() const { return dense_due_; }
  // The dense phase of an increment: sweeps the new key views, fuses, and
  // returns the writes of a further model version with the new cloud. The
  // sparse phase (run) publishes first, so that a photo shows up registered
  // without waiting for its depth map. Throws like run(). In one go, all
  // under publication(): begin_dense, compute_dense, finish_dense.
  Increment run_dense();
  // The dense phase in three steps (see DenseTask): nullopt when none is
  // due or one is under way already. A failed compute_dense() is followed
  // by reset() (the stored state still says the cloud is due). finish_dense
  // returns no writes when the job was reset since begin_dense (its work is
  // dropped; the restored state has the dense phase due).
  std::optional<DenseTask> begin_dense();
  void compute_dense(DenseTask& task);
  Increment finish_dense(DenseTask& task);
  // Held by whoever calls a member other than compute_dense, from the call
  // until its writes are committed and committed() returned.
  std::mutex& publication() { return publication_; }
  // True when the site's global refinement has work (Reconstruction::
  // refinement_due): the worker runs it while no work is waiting.
  bool refinement_due() const;
  // Due, and a merge or a loop closure moved cameras since it last settled
  // (Reconstruction::refinement_urgent): it goes before the dense lane
  // then.
  bool refinement_urgent() const;
  // The global refinement between increments: `stop` is asked after every
  // solver iteration and ends it early (the progress stands). Returns the
  // writes of a model version with the refined poses and the engine state,
  // or no writes when nothing was due. A refinement that ran makes the
  // dense phase due (the depth maps follow the moved cameras; the model
  // says `dense_state` "pending" until then). Throws like run().
  Increment run_refine(const std::function<bool()>& stop);
  // Takes `other`'s site in (two sites that grew together; the worker has
  // moved its captures here in the directory): its reconstruction joins
  // this one (Reconstruction::absorb), its captures' features and statuses
  // are written under this site, its own documents (model, engine state,
  // features, depth maps, dense tiles) are deleted, and a model version
  // with both is published; its swept views are swept again here, in this
  // site's frame. `other` is reset (its state lives here now). Neither
  // job's lanes may run meanwhile. Throws like run(), and
  // std::invalid_argument when the models cannot join (no fixes).
  Increment absorb(SiteJob& other);
  // The batch of the last run(), run_dense() or run_refine() committed.
  void committed();
  // Forgets the in-memory state: the next run() restores it from the store.
  void reset();

  int registered() const;
  std::int64_t model_version() const { return model_version_; }

 private:
  void restore();
  // Forgets the writes of a call whose batch was not committed.
  void clear_pending();
  DenseOptions lane_dense_options() const;
  // Patches of the captures whose status changed since last published.
  void add_status_ops(const std::vector<CaptureState>& captures,
                      std::vector<db::WriteOp>* ops);
  // `added`: captures new in this batch, whose features are written even
  // when a capture of that id had some stored (withdrawn and sent again).
  // Returns the size of the serialized state (all its parts).
  size_t add_state_ops(const Model& model,
                       const std::vector<std::string>& added,
                       std::vector<db::WriteOp>* ops);
  // `new_cloud` and `new_mesh`: the tiles a dense phase publishes;
  // otherwise the last published ones stay.
  void add_mesh_tile_ops(const std::vector<MeshTileEntry>& tiles,
                         std::vector<db::WriteOp>* ops) const;
  db::WriteOp model_op(const Model& model,
                       const std::vector<CaptureState>& captures,
                       const IncrementReport& report,
                       const DenseTiles* new_cloud = nullptr,
                       const std::set<std::string>* new_views = nullptr,
                       const MeshBuild* new_mesh = nullptr);
  // `more_follow`: the increment adds more captures after this one
  // (CaptureInput::more_follow).
  void add(const std::string& capture, bool more_follow,
           IncrementReport* report);
  // Hands the features of the captures `report` added to feature_writer_.
  void start_feature_writes(const IncrementReport& report);
  // The stored blob of `capture`'s features: the one feature_writer_ stored
  // for it, or stored now.
  std::string features_blob(const std::string& capture);
  std::string dense_summary(const DenseTask& task, bool model_published) const;
  void add_tile_ops(const DenseTiles& tiles,
                    std::vector<db::WriteOp>* ops) const;
  // Whether a dense phase with `update` leaves its tiles unstored for now
  // (WorkerOptions::dense_tile_interval): more of the lane's work follows
  // and the last store is recent.
  bool tiles_wait(const DenseUpdate& update) const;
  // Deletions of this site's engine documents (it was merged away).
  void add_departure_ops(std::vector<db::WriteOp>* ops) const;
  std::string image_bytes(const std::string& capture);

  std::string id_;
  db::Store& store_;
  const WorkerOptions& options_;
  CapturePreparer* const preparer_;
  // When the dense lane last stored tiles (none yet: the first phase does).
  std::optional<std::chrono::steady_clock::time_point> tiles_stored_at_;
  bool loaded_ = false;
  std::unique_ptr<Reconstruction> sparse_;
  std::shared_ptr<DenseReconstruction> dense_;
  std::uint64_t generation_ = 0;  // restores so far
  std::mutex publication_;
  std::mutex images_mutex_;                      // both lanes read photos
  std::map<std::string, std::string> images_;    // capture -> image sha
  std::map<std::string, std::string> statuses_;  // as last published
  std::set<std::string> depth_maps_;             // stored under depth/
  std::map<std::string, std::string> pending_statuses_;
  std::set<std::string> pending_depth_maps_, pending_removed_maps_;
  // Captures whose features are stored under features/ (once each: the
  // state blob leaves them out).
  std::set<std::string> features_, pending_features_, pending_removed_features_;
  // The features of captures added since the state was saved, being stored
  // by feature_writer_ (their documents are written with the state).
  std::map<std::string, std::shared_future<std::string>> feature_writes_;
  BlobWriter feature_writer_;
  std::int64_t model_version_ = 0;
  std::int64_t pending_model_version_ = 0;
  std::int64_t engine_version_ = 0;  // of /sites/{id}/engine, 0: none yet
  // Whether the pending writes touch the engine document (its version
  // then moves) and hold the state; whether committed work is unsaved.
  bool pending_engine_written_ = false;
  bool pending_state_written_ = false;
  bool pending_unsaved_ = false;  // a run() that left the state out
  bool state_unsaved_ = false;
  std::chrono::steady_clock::time_point unsaved_since_;
  std::chrono::steady_clock::time_point last_commit_ =
      std::chrono::steady_clock::now();
  // The highest change seq folded into the state (attrs.through_seq).
  std::int64_t through_seq_ = 0;
  std::int64_t pending_through_seq_ = 0;
  // The dense phase still to run, and what it covers; one taken by
  // begin_dense and not yet committed (or dropped by a reset).
  bool dense_due_ = false;
  bool dense_in_flight_ = false;
  bool dense_finishing_ = false;  // the writes of finish_dense await commit
  std::vector<std::string> dense_added_, dense_withdrawn_;
  DenseTiles dense_tiles_, pending_dense_tiles_;  // the published cloud
  std::vector<MeshTileEntry> mesh_tiles_, pending_mesh_tiles_;  // surface
  MeshCursor mesh_cursor_, pending_mesh_cursor_;  // with mesh_tiles_
  std::size_t dense_points_ = 0, pending_dense_points_ = 0;
  // The views the published cloud covers.
  std::set<std::string> dense_views_, pending_dense_views_;
};

}  // namespace arscout::engine::service
