// The pieces the server holds hostile clients with (docs/RELIABILITY.md,
// "Hostile clients"): caps per key, the minimum body rate, and the change
// watch that long-polls and streams wait on without a thread.
#include <atomic>
#include <chrono>
#include <thread>

#include <gtest/gtest.h>

#include "arscout/db/store.h"
#include "arscout/http/body_rate.h"
#include "arscout/http/keyed_limit.h"
#include "change_watch.h"
#include "test_stores.h"

namespace arscout::ingest {

using http::BodyRate;
using http::KeyedLimit;
namespace {

using namespace std::chrono_literals;

TEST(KeyedLimit, RefusesPastEitherCapAndReleasesWithTheSlot) {
  KeyedLimit limit(3, 2);
  auto a1 = limit.acquire("a");
  auto a2 = limit.acquire("a");
  ASSERT_TRUE(a1 && a2);
  EXPECT_FALSE(limit.acquire("a"));  // a's cap
  auto b1 = limit.acquire("b");
  ASSERT_TRUE(b1);
  EXPECT_FALSE(limit.acquire("c"));  // the total
  EXPECT_EQ(limit.in_use(), 3u);
  a1.reset();
  EXPECT_EQ(limit.in_use("a"), 1u);
  auto c1 = limit.acquire("c");
  EXPECT_TRUE(c1);
  // Moving a slot moves what it holds; assigning over one releases it.
  KeyedLimit::Slot moved = std::move(*b1);
  b1.reset();
  EXPECT_EQ(limit.in_use("b"), 1u);
  moved = std::move(*c1);
  EXPECT_EQ(limit.in_use("b"), 0u);
  EXPECT_EQ(limit.in_use("c"), 1u);
}

TEST(KeyedLimit, ZeroMeansNoCapAndASlotMayOutliveItsLimit) {
  std::optional<KeyedLimit::Slot> kept;
  {
    KeyedLimit unlimited(0, 0);
    std::vector<KeyedLimit::Slot> slots;
    for (int i = 0; i < 1000; ++i) slots.push_back(*unlimited.acquire("k"));
    EXPECT_EQ(unlimited.in_use("k"), 1000u);
    kept = unlimited.acquire("k");
  }
  kept.reset();  // the limit is gone; releasing is still safe
}

TEST(BodyRate, AWindowBelowTheMinimumFails) {
  const auto t0 = BodyRate::Clock::time_point{} + 100s;
  BodyRate rate(1024, 10s);
  rate.start(t0);
  EXPECT_TRUE(rate.add(1, t0 + 4s));
  EXPECT_TRUE(rate.add(1, t0 + 8s));
  EXPECT_FALSE(rate.add(1, t0 + 12s));  // 3 bytes in 12 s
  BodyRate fast(1024, 10s);
  fast.start(t0);
  for (int s = 1; s <= 60; ++s) EXPECT_TRUE(fast.add(2048, t0 + s * 1s));
  // A pause within a window is forgiven when the window makes up for it.
  BodyRate bursty(1024, 10s);
  bursty.start(t0);
  EXPECT_TRUE(bursty.add(20000, t0 + 9s));
  EXPECT_TRUE(bursty.add(1, t0 + 10s));
  BodyRate off(0);
  off.start(t0);
  EXPECT_TRUE(off.add(0, t0 + 1000s));
}

class ChangeWatchTest : public ::testing::Test {
 protected:
  void SetUp() override {
    url_ = testing::fresh_sqlite_url();
    store_ = db::Store::open(url_);
  }
  std::string url_;
  std::unique_ptr<db::Store> store_;
};

TEST_F(ChangeWatchTest, WakesWaitersOnceTheLogPassesThem) {
  ChangeWatch watch(*store_, 100ms);
  const std::int64_t head = store_->last_seq();
  std::atomic<int> woken{0}, cancelled{0};
  for (int i = 0; i < 100; ++i) watch.notify_after(head, [&] { ++woken; });
  const auto id = watch.notify_after(head, [&] { ++cancelled; });
  watch.cancel(id);
  std::this_thread::sleep_for(200ms);
  EXPECT_EQ(woken, 0);
  EXPECT_EQ(watch.waiting(), 100u);
  store_->put("/notes/a", "note", db::Json{{"n", 1}});
  for (int i = 0; i < 50 && woken < 100; ++i) std::this_thread::sleep_for(20ms);
  EXPECT_EQ(woken, 100);
  EXPECT_EQ(cancelled, 0);
  EXPECT_EQ(watch.waiting(), 0u);
  // A waiter already passed is woken at once, on the caller's thread.
  bool at_once = false;
  watch.notify_after(head, [&] { at_once = true; });
  EXPECT_TRUE(at_once);
}

TEST_F(ChangeWatchTest, NoticesWritesOfAnotherStoreHandle) {
  // Another handle on the same file stands for another process: no
  // in-process wake-up reaches the watch, its poll finds the write.
  ChangeWatch watch(*store_, 50ms);
  const std::int64_t head = store_->last_seq();
  std::atomic<bool> woken{false};
  watch.notify_after(head, [&] { woken = true; });
  auto other = db::Store::open(url_);
  other->put("/notes/b", "note", db::Json{{"n", 2}});
  for (int i = 0; i < 100 && !woken; ++i) std::this_thread::sleep_for(20ms);
  EXPECT_TRUE(woken);
}

TEST_F(ChangeWatchTest, StopDropsWaitersUnwoken) {
  std::atomic<int> woken{0};
  {
    ChangeWatch watch(*store_, 100ms);
    watch.notify_after(store_->last_seq(), [&] { ++woken; });
    watch.stop();
    EXPECT_EQ(watch.notify_after(-1, [&] { ++woken; }), 0u);
  }
  EXPECT_EQ(woken, 0);
}

}  // namespace
}  // namespace arscout::ingest
