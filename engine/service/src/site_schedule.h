// The scheduler's state of one site: what each of its lanes is doing and
// what is due, as enums that change only through the transition tables in
// site_schedule.cpp (docs/service.md, "Scheduling").
//
// A site has two lanes. The sparse lane runs its increments, its
// refinement, its engine-state saves, and is held while another site takes
// it in (a merge). The dense lane queues, takes its turn at the site's
// publication to begin, sweeps beside the sparse lane, and takes its turn
// again to publish. What is due beside them: a refinement (wanted now, or
// deferred until the site's refinement interval has passed) and a dense
// catch-up after a failed dense phase (run in the sparse lane).
//
// SiteSchedule holds no lock and starts no thread: the worker calls it under
// its own mutex, and the tests drive it event by event. An event that its
// table does not allow from the current state is a scheduler bug: on()
// throws std::logic_error and changes nothing.
#pragma once

#include <deque>
#include <set>
#include <string>
#include <string_view>

namespace arscout::engine::service {

enum class SparseState {
  kIdle,
  kRunning,      // an increment, a merge into it, or a refinement
  kSaving,       // saving a quiet site's engine state
  kHeldByMerge,  // another site is taking this one in
};

enum class DenseState {
  kIdle,
  kQueued,         // due, waiting for a dense-lane thread
  kTurnToBegin,    // waiting for the site's publication to take its model
  kSweeping,       // sweeping and fusing beside the sparse lane
  kTurnToPublish,  // waiting for (or holding) publication to commit
};

enum class RefinementState {
  kNone,
  kWanted,    // runs when the sparse lane next picks the site up
  kDeferred,  // wanted once WorkerOptions::refinement_interval has passed
};

enum class SiteEvent {
  // Sparse lane.
  kSparseBegin,   // kIdle -> kRunning; takes the wanted refinement
  kSparseEnd,     // kRunning -> kIdle
  kSaveBegin,     // kIdle -> kSaving
  kSaveEnd,       // kSaving -> kIdle
  kMergeHold,     // kIdle -> kHeldByMerge
  kMergeRelease,  // kHeldByMerge -> kIdle
  // Dense lane.
  kDenseDue,      // kIdle -> kQueued; already queued or running: unchanged
  kDenseTaken,    // kQueued -> kTurnToBegin
  kDenseSkipped,  // kQueued -> kIdle (lease lost, site being merged)
  kDenseBegun,    // kTurnToBegin -> kSweeping
  kDenseSwept,    // kSweeping -> kTurnToPublish
  kDenseEnded,    // any running state -> kIdle
  kDenseFailed,   // any running state -> kIdle; a catch-up becomes due
  // Refinement.
  kRefineWanted,          // -> kWanted
  kRefineTooSoon,         // -> kDeferred
  kRefineIntervalPassed,  // kDeferred -> kWanted
  kRefineDropped,         // -> kNone (work came first: its increment refines)
};

std::string_view to_string(SparseState state);
std::string_view to_string(DenseState state);
std::string_view to_string(RefinementState state);
std::string_view to_string(SiteEvent event);

class SiteSchedule {
 public:
  // Applies `event` by its lane's transition table; throws
  // std::logic_error, naming the state and the event, when the table has
  // no row for them.
  void on(SiteEvent event);

  SparseState sparse() const { return sparse_; }
  DenseState dense() const { return dense_; }
  RefinementState refinement() const { return refinement_; }

  // Work for the sparse lane besides queued captures and merges: a dense
  // catch-up or a wanted refinement.
  bool sparse_due() const {
    return dense_catch_up_ || refinement_ == RefinementState::kWanted;
  }
  // A dense phase failed: the sparse lane's next pick-up catches up
  // (cleared by kSparseBegin, which is when it is taken).
  bool dense_catch_up() const { return dense_catch_up_; }

  // No lane of the site is doing or waiting to do anything: it may be
  // taken into another site.
  bool lanes_idle() const {
    return sparse_ == SparseState::kIdle && dense_ == DenseState::kIdle;
  }
  // Nothing running, queued or due in any lane (the worker is idle when
  // every site is, with no capture waiting).
  bool quiet() const {
    return lanes_idle() && refinement_ == RefinementState::kNone &&
           !dense_catch_up_;
  }
  bool sparse_busy() const { return sparse_ != SparseState::kIdle; }
  bool dense_running() const {
    return dense_ != DenseState::kIdle && dense_ != DenseState::kQueued;
  }
  // The dense lane waits for, or holds, the site's publication: the sparse
  // lane lets it go first.
  bool dense_turn() const {
    return dense_ == DenseState::kTurnToBegin ||
           dense_ == DenseState::kTurnToPublish;
  }
  // The dense lane has work that a refinement gives way to: not a lane
  // whose last phase only re-fused moved maps (set_refusing_only).
  bool dense_busy() const {
    return dense_ != DenseState::kIdle && !refusing_only_;
  }

  // What the dense lane's last phase did: it swept no view and left none
  // waiting (it only re-fuses maps whose cameras moved). Cleared when an
  // increment or a merge gives it views to sweep.
  void set_refusing_only(bool refusing_only) { refusing_only_ = refusing_only; }

 private:
  SparseState sparse_ = SparseState::kIdle;
  DenseState dense_ = DenseState::kIdle;
  RefinementState refinement_ = RefinementState::kNone;
  bool dense_catch_up_ = false;
  bool refusing_only_ = false;
};

// The sites whose sparse lane has work, in the order it came: each at most
// once (a site already waiting keeps its place).
class ReadyQueue {
 public:
  // Appends `site` unless it is waiting already; whether it was appended.
  bool push(const std::string& site);
  // The oldest waiting site, removed; call only when !empty().
  std::string pop();
  bool contains(const std::string& site) const { return waiting_.count(site); }
  bool empty() const { return order_.empty(); }
  void clear();

 private:
  std::deque<std::string> order_;
  std::set<std::string> waiting_;
};

}  // namespace arscout::engine::service
