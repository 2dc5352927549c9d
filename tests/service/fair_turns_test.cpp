// Fair turns between scouts: which queued captures an increment takes.
#include "fair_turns.h"

#include <gtest/gtest.h>

#include <string>

namespace arscout::engine::service {
namespace {

Work add(const std::string& scout, int n, std::int64_t seq) {
  return Work{Work::Kind::kAdd, scout + std::to_string(n), seq, scout};
}

std::vector<std::string> ids(const std::vector<Work>& works) {
  std::vector<std::string> out;
  for (const Work& w : works) out.push_back(w.capture);
  return out;
}

TEST(FairTurns, AnotherScoutsPhotoIsNotStarvedByABurst) {
  std::deque<Work> pending;
  for (int i = 1; i <= 50; ++i) pending.push_back(add("alice", i, i));
  pending.push_back(add("bob", 1, 51));
  const std::vector<Work> taken = take_in_turns(pending, 4);
  EXPECT_EQ(ids(taken),
            (std::vector<std::string>{"alice1", "bob1", "alice2", "alice3"}));
  ASSERT_EQ(pending.size(), 47u);
  EXPECT_EQ(pending.front().capture, "alice4");
  // Everything up to alice3 is settled; alice4 (seq 4) is not.
  EXPECT_EQ(settled_through(taken, pending), 3);
}

TEST(FairTurns, EachScoutKeepsItsOrderAndAWithdrawalStaysAfter) {
  std::deque<Work> pending = {add("a", 1, 1), add("b", 1, 2), add("a", 2, 3),
                              add("c", 1, 4), add("b", 2, 5)};
  pending.push_back(Work{Work::Kind::kWithdraw, "a1", 6, "a"});
  std::vector<std::string> order;
  std::vector<Work::Kind> kinds;
  while (!pending.empty()) {
    for (const Work& w : take_in_turns(pending, 2)) {
      order.push_back(w.capture);
      kinds.push_back(w.kind);
    }
  }
  // Turns of two: (a1 b1) (a2 c1) (b2 a1-withdrawn).
  EXPECT_EQ(order,
            (std::vector<std::string>{"a1", "b1", "a2", "c1", "b2", "a1"}));
  EXPECT_EQ(kinds.back(), Work::Kind::kWithdraw);
}

TEST(FairTurns, OneAtATimeIsArrivalOrder) {
  std::deque<Work> pending = {add("b", 1, 7), add("a", 1, 8), add("b", 2, 9)};
  std::vector<std::string> order;
  while (!pending.empty()) {
    const std::vector<Work> taken = take_in_turns(pending, 0);  // one
    ASSERT_EQ(taken.size(), 1u);
    order.push_back(taken[0].capture);
  }
  EXPECT_EQ(order, (std::vector<std::string>{"b1", "a1", "b2"}));
}

TEST(FairTurns, AllTakenSettlesThroughTheNewest) {
  std::deque<Work> pending = {add("a", 1, 3), add("b", 1, 9)};
  const std::vector<Work> taken = take_in_turns(pending, 8);
  EXPECT_TRUE(pending.empty());
  EXPECT_EQ(settled_through(taken, pending), 9);
}

}  // namespace
}  // namespace arscout::engine::service
