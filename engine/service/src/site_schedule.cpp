// The transition tables of a site's lanes: every state change of the
// scheduler is one row here (docs/service.md, "Scheduling").
#include "site_schedule.h"

#include <span>
#include <stdexcept>
#include <string>

namespace arscout::engine::service {
namespace {

template <typename State>
struct Row {
  State from;
  SiteEvent event;
  State to;
};

using S = SparseState;
using D = DenseState;
using R = RefinementState;
using E = SiteEvent;

constexpr Row<S> kSparseRows[] = {
    {S::kIdle, E::kSparseBegin, S::kRunning},
    {S::kRunning, E::kSparseEnd, S::kIdle},
    {S::kIdle, E::kSaveBegin, S::kSaving},
    {S::kSaving, E::kSaveEnd, S::kIdle},
    {S::kIdle, E::kMergeHold, S::kHeldByMerge},
    {S::kHeldByMerge, E::kMergeRelease, S::kIdle},
};

constexpr Row<D> kDenseRows[] = {
    {D::kIdle, E::kDenseDue, D::kQueued},
    // Due while queued or running: the lane's end asks the job again.
    {D::kQueued, E::kDenseDue, D::kQueued},
    {D::kTurnToBegin, E::kDenseDue, D::kTurnToBegin},
    {D::kSweeping, E::kDenseDue, D::kSweeping},
    {D::kTurnToPublish, E::kDenseDue, D::kTurnToPublish},
    {D::kQueued, E::kDenseTaken, D::kTurnToBegin},
    {D::kQueued, E::kDenseSkipped, D::kIdle},
    {D::kTurnToBegin, E::kDenseBegun, D::kSweeping},
    {D::kSweeping, E::kDenseSwept, D::kTurnToPublish},
    // begin_dense found nothing to sweep: the lane ends without sweeping.
    {D::kSweeping, E::kDenseEnded, D::kIdle},
    {D::kTurnToPublish, E::kDenseEnded, D::kIdle},
    {D::kTurnToBegin, E::kDenseFailed, D::kIdle},
    {D::kSweeping, E::kDenseFailed, D::kIdle},
    {D::kTurnToPublish, E::kDenseFailed, D::kIdle},
    // Deterministic runs sweep in the sparse lane, the dense lane idle.
    {D::kIdle, E::kDenseFailed, D::kIdle},
};

constexpr Row<R> kRefinementRows[] = {
    {R::kNone, E::kSparseBegin, R::kNone},
    {R::kWanted, E::kSparseBegin, R::kNone},
    {R::kDeferred, E::kSparseBegin, R::kDeferred},
    {R::kNone, E::kRefineWanted, R::kWanted},
    {R::kWanted, E::kRefineWanted, R::kWanted},
    {R::kDeferred, E::kRefineWanted, R::kWanted},
    {R::kNone, E::kRefineTooSoon, R::kDeferred},
    {R::kWanted, E::kRefineTooSoon, R::kDeferred},
    {R::kDeferred, E::kRefineTooSoon, R::kDeferred},
    {R::kDeferred, E::kRefineIntervalPassed, R::kWanted},
    {R::kNone, E::kRefineDropped, R::kNone},
    {R::kWanted, E::kRefineDropped, R::kNone},
    {R::kDeferred, E::kRefineDropped, R::kDeferred},
};

template <typename State>
bool mentions(std::span<const Row<State>> rows, SiteEvent event) {
  for (const Row<State>& row : rows)
    if (row.event == event) return true;
  return false;
}

// The state `event` leads to from `state` by `rows`: `state` itself when
// the table does not speak of the event; throws when it does, but not from
// `state`.
template <typename State>
State next(std::span<const Row<State>> rows, State state, SiteEvent event) {
  if (!mentions(rows, event)) return state;
  for (const Row<State>& row : rows)
    if (row.event == event && row.from == state) return row.to;
  throw std::logic_error("site scheduler: no transition for " +
                         std::string(to_string(event)) + " from " +
                         std::string(to_string(state)));
}

}  // namespace

void SiteSchedule::on(SiteEvent event) {
  // Every table is checked before any state changes.
  const SparseState sparse = next<S>(kSparseRows, sparse_, event);
  const DenseState dense = next<D>(kDenseRows, dense_, event);
  const RefinementState refinement =
      next<R>(kRefinementRows, refinement_, event);
  sparse_ = sparse;
  dense_ = dense;
  refinement_ = refinement;
  if (event == E::kDenseFailed) dense_catch_up_ = true;
  if (event == E::kSparseBegin) dense_catch_up_ = false;
}

std::string_view to_string(SparseState state) {
  switch (state) {
    case S::kIdle:
      return "idle";
    case S::kRunning:
      return "running";
    case S::kSaving:
      return "saving";
    case S::kHeldByMerge:
      return "held-by-merge";
  }
  return "?";
}

std::string_view to_string(DenseState state) {
  switch (state) {
    case D::kIdle:
      return "idle";
    case D::kQueued:
      return "queued";
    case D::kTurnToBegin:
      return "turn-to-begin";
    case D::kSweeping:
      return "sweeping";
    case D::kTurnToPublish:
      return "turn-to-publish";
  }
  return "?";
}

std::string_view to_string(RefinementState state) {
  switch (state) {
    case R::kNone:
      return "none";
    case R::kWanted:
      return "wanted";
    case R::kDeferred:
      return "deferred";
  }
  return "?";
}

std::string_view to_string(SiteEvent event) {
  switch (event) {
    case E::kSparseBegin:
      return "sparse-begin";
    case E::kSparseEnd:
      return "sparse-end";
    case E::kSaveBegin:
      return "save-begin";
    case E::kSaveEnd:
      return "save-end";
    case E::kMergeHold:
      return "merge-hold";
    case E::kMergeRelease:
      return "merge-release";
    case E::kDenseDue:
      return "dense-due";
    case E::kDenseTaken:
      return "dense-taken";
    case E::kDenseSkipped:
      return "dense-skipped";
    case E::kDenseBegun:
      return "dense-begun";
    case E::kDenseSwept:
      return "dense-swept";
    case E::kDenseEnded:
      return "dense-ended";
    case E::kDenseFailed:
      return "dense-failed";
    case E::kRefineWanted:
      return "refine-wanted";
    case E::kRefineTooSoon:
      return "refine-too-soon";
    case E::kRefineIntervalPassed:
      return "refine-interval-passed";
    case E::kRefineDropped:
      return "refine-dropped";
  }
  return "?";
}

bool ReadyQueue::push(const std::string& site) {
  if (!waiting_.insert(site).second) return false;
  order_.push_back(site);
  return true;
}

std::string ReadyQueue::pop() {
  std::string site = std::move(order_.front());
  order_.pop_front();
  waiting_.erase(site);
  return site;
}

void ReadyQueue::clear() {
  order_.clear();
  waiting_.clear();
}

}  // namespace arscout::engine::service
