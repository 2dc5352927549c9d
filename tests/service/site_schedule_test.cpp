// The scheduler's per-site states and transitions (site_schedule.h), driven
// event by event without threads.
#include "site_schedule.h"

#include <gtest/gtest.h>

#include <deque>
#include <set>
#include <stdexcept>
#include <tuple>
#include <vector>

namespace arscout::engine::service {
namespace {

using E = SiteEvent;

constexpr E kAllEvents[] = {E::kSparseBegin,   E::kSparseEnd,
                            E::kSaveBegin,     E::kSaveEnd,
                            E::kMergeHold,     E::kMergeRelease,
                            E::kDenseDue,      E::kDenseTaken,
                            E::kDenseSkipped,  E::kDenseBegun,
                            E::kDenseSwept,    E::kDenseEnded,
                            E::kDenseFailed,   E::kRefineWanted,
                            E::kRefineTooSoon, E::kRefineIntervalPassed,
                            E::kRefineDropped};

SiteSchedule after(std::initializer_list<E> events) {
  SiteSchedule s;
  for (E e : events) s.on(e);
  return s;
}

TEST(SiteSchedule, AnIncrementAndADensePhaseRunSideBySide) {
  SiteSchedule s;
  EXPECT_TRUE(s.quiet());
  s.on(E::kSparseBegin);
  EXPECT_EQ(s.sparse(), SparseState::kRunning);
  s.on(E::kDenseDue);
  EXPECT_EQ(s.dense(), DenseState::kQueued);
  s.on(E::kSparseEnd);
  s.on(E::kDenseTaken);
  EXPECT_TRUE(s.dense_turn());  // the sparse lane lets it begin first
  s.on(E::kDenseBegun);
  EXPECT_FALSE(s.dense_turn());
  s.on(E::kSparseBegin);  // the next increment, beside the sweep
  EXPECT_TRUE(s.dense_running());
  EXPECT_FALSE(s.lanes_idle());
  s.on(E::kDenseSwept);
  EXPECT_EQ(s.dense(), DenseState::kTurnToPublish);
  EXPECT_TRUE(s.dense_turn());
  s.on(E::kDenseEnded);
  s.on(E::kSparseEnd);
  EXPECT_TRUE(s.quiet());
}

TEST(SiteSchedule, AnEventTheTableDoesNotAllowThrowsAndChangesNothing) {
  const std::vector<std::pair<SiteSchedule, E>> wrong = {
      {after({}), E::kSparseEnd},
      {after({E::kSparseBegin}), E::kSparseBegin},
      {after({E::kSparseBegin}), E::kSaveBegin},
      {after({E::kSparseBegin}), E::kMergeHold},
      {after({E::kSaveBegin}), E::kSparseEnd},
      {after({E::kDenseDue}), E::kDenseBegun},
      {after({}), E::kDenseTaken},
      {after({E::kDenseDue, E::kDenseTaken}), E::kDenseSwept},
      {after({E::kDenseDue}), E::kDenseEnded},
      {after({}), E::kRefineIntervalPassed},
  };
  for (auto [schedule, event] : wrong) {
    const auto before =
        std::make_tuple(schedule.sparse(), schedule.dense(),
                        schedule.refinement(), schedule.dense_catch_up());
    EXPECT_THROW(schedule.on(event), std::logic_error) << to_string(event);
    EXPECT_EQ(before,
              std::make_tuple(schedule.sparse(), schedule.dense(),
                              schedule.refinement(), schedule.dense_catch_up()))
        << to_string(event);
  }
}

TEST(SiteSchedule, DueWhileQueuedOrRunningQueuesNothingMore) {
  SiteSchedule s = after({E::kDenseDue, E::kDenseTaken, E::kDenseBegun});
  s.on(E::kDenseDue);
  EXPECT_EQ(s.dense(), DenseState::kSweeping);
}

TEST(SiteSchedule, AFailedDensePhaseIsCaughtUpByTheNextPickUp) {
  SiteSchedule s = after({E::kDenseDue, E::kDenseTaken, E::kDenseBegun});
  s.on(E::kDenseFailed);
  EXPECT_EQ(s.dense(), DenseState::kIdle);
  EXPECT_TRUE(s.dense_catch_up());
  EXPECT_TRUE(s.sparse_due());
  EXPECT_FALSE(s.quiet());
  s.on(E::kSparseBegin);  // takes it
  EXPECT_FALSE(s.dense_catch_up());
  EXPECT_FALSE(s.sparse_due());
  // Inline (deterministic runs): the dense lane stays idle.
  SiteSchedule inline_run = after({E::kSparseBegin, E::kDenseFailed});
  EXPECT_TRUE(inline_run.dense_catch_up());
}

TEST(SiteSchedule, ARefinementIsWantedDeferredAndWoken) {
  SiteSchedule s = after({E::kRefineWanted});
  EXPECT_TRUE(s.sparse_due());
  s.on(E::kSparseBegin);  // the pick-up takes a wanted one
  EXPECT_EQ(s.refinement(), RefinementState::kNone);
  s.on(E::kRefineTooSoon);
  s.on(E::kSparseEnd);
  EXPECT_EQ(s.refinement(), RefinementState::kDeferred);
  EXPECT_FALSE(s.sparse_due());  // not until the interval passes
  s.on(E::kSparseBegin);         // a pick-up for work keeps it deferred
  EXPECT_EQ(s.refinement(), RefinementState::kDeferred);
  s.on(E::kSparseEnd);
  s.on(E::kRefineDropped);  // the dense lane's end does not drop it
  EXPECT_EQ(s.refinement(), RefinementState::kDeferred);
  s.on(E::kRefineIntervalPassed);
  EXPECT_EQ(s.refinement(), RefinementState::kWanted);
  s.on(E::kRefineDropped);
  EXPECT_TRUE(s.quiet());
}

TEST(SiteSchedule, ARefinementGivesWayOnlyToADenseLaneWithViewsToSweep) {
  SiteSchedule s = after({E::kDenseDue});
  EXPECT_TRUE(s.dense_busy());
  s.set_refusing_only(true);  // its last phase only re-fused moved maps
  EXPECT_FALSE(s.dense_busy());
  s.set_refusing_only(false);
  s.on(E::kDenseSkipped);
  EXPECT_FALSE(s.dense_busy());
}

TEST(SiteSchedule, ASiteIsHeldForAMergeOnlyWithItsLanesIdle) {
  SiteSchedule s;
  s.on(E::kMergeHold);
  EXPECT_EQ(s.sparse(), SparseState::kHeldByMerge);
  EXPECT_TRUE(s.sparse_busy());
  EXPECT_THROW(s.on(E::kSparseBegin), std::logic_error);
  s.on(E::kMergeRelease);
  EXPECT_TRUE(s.lanes_idle());
  SiteSchedule saving = after({E::kSaveBegin});
  EXPECT_FALSE(saving.lanes_idle());
  EXPECT_THROW(saving.on(E::kMergeHold), std::logic_error);
}

// Every state the events can reach leads back to quiet: the tables have no
// state that a site cannot leave.
TEST(SiteSchedule, EveryReachableStateLeadsBackToQuiet) {
  using Key = std::tuple<SparseState, DenseState, RefinementState, bool>;
  auto key = [](const SiteSchedule& s) {
    return Key{s.sparse(), s.dense(), s.refinement(), s.dense_catch_up()};
  };
  std::vector<SiteSchedule> states{SiteSchedule{}};
  std::set<Key> seen{key(states.front())};
  std::vector<std::vector<std::size_t>> edges(1);
  for (std::size_t i = 0; i < states.size(); ++i) {
    for (E event : kAllEvents) {
      SiteSchedule next = states[i];
      try {
        next.on(event);
      } catch (const std::logic_error&) {
        continue;
      }
      if (seen.insert(key(next)).second) {
        states.push_back(next);
        edges.emplace_back();
      }
      for (std::size_t j = 0; j < states.size(); ++j)
        if (key(states[j]) == key(next)) edges[i].push_back(j);
    }
  }
  // 4 sparse x 5 dense x 3 refinement x catch-up, less the combinations
  // the tables forbid.
  EXPECT_GT(states.size(), 60u);
  for (std::size_t start = 0; start < states.size(); ++start) {
    std::set<std::size_t> reached{start};
    std::deque<std::size_t> frontier{start};
    bool quiet = false;
    while (!frontier.empty() && !quiet) {
      const std::size_t at = frontier.front();
      frontier.pop_front();
      quiet = states[at].quiet();
      for (std::size_t to : edges[at])
        if (reached.insert(to).second) frontier.push_back(to);
    }
    EXPECT_TRUE(quiet) << "stuck: sparse " << to_string(states[start].sparse())
                       << ", dense " << to_string(states[start].dense());
  }
}

TEST(ReadyQueue, KeepsEachSiteOnceInTheOrderItCame) {
  ReadyQueue q;
  EXPECT_TRUE(q.push("a"));
  EXPECT_TRUE(q.push("b"));
  EXPECT_FALSE(q.push("a"));
  EXPECT_TRUE(q.contains("a"));
  EXPECT_EQ(q.pop(), "a");
  EXPECT_FALSE(q.contains("a"));
  EXPECT_TRUE(q.push("a"));
  EXPECT_EQ(q.pop(), "b");
  EXPECT_EQ(q.pop(), "a");
  EXPECT_TRUE(q.empty());
}

}  // namespace
}  // namespace arscout::engine::service
