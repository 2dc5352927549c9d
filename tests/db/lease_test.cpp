// Leases (Store::claim_leases and friends), identically on every backend.
#include <atomic>
#include <set>
#include <thread>

#include <gtest/gtest.h>

#include "arscout/db/store.h"
#include "test_stores.h"

namespace arscout::db {
namespace {

using namespace std::chrono_literals;
using Names = std::vector<std::string>;

class Leases : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    ARSCOUT_FRESH_STORE_OR_SKIP(url_, GetParam());
    store_ = Store::open(url_);
  }

  std::optional<Lease> lease(const std::string& name) {
    for (const Lease& l : store_->leases(name))
      if (l.name == name) return l;
    return std::nullopt;
  }

  std::string url_;
  std::unique_ptr<Store> store_;
};

TEST_P(Leases, AFreeLeaseIsTakenAndAHeldOneIsNot) {
  EXPECT_EQ(store_->claim_leases({"site/a", "site/b"}, "w1", 30s, 10),
            (Names{"site/a", "site/b"}));
  EXPECT_EQ(store_->claim_leases({"site/a", "site/b", "site/c"}, "w2", 30s, 10),
            (Names{"site/c"}));
  auto a = lease("site/a");
  ASSERT_TRUE(a);
  EXPECT_EQ(a->holder, "w1");
  EXPECT_GT(a->remaining, 25s);
  EXPECT_LE(a->remaining, 30s);
  EXPECT_EQ(a->generation, 1);
  // Claiming what one holds renews it and takes nothing new.
  EXPECT_EQ(store_->claim_leases({"site/a"}, "w1", 60s, 0), (Names{"site/a"}));
  EXPECT_GT(lease("site/a")->remaining, 55s);
  EXPECT_EQ(lease("site/a")->generation, 1);
}

TEST_P(Leases, MaxNewLimitsWhatOneClaimTakes) {
  EXPECT_EQ(store_->claim_leases({"s/3", "s/1", "s/2"}, "w1", 30s, 2),
            (Names{"s/1", "s/2"}));
  EXPECT_EQ(store_->claim_leases({"s/1", "s/2", "s/3"}, "w1", 30s, 0),
            (Names{"s/1", "s/2"}));
  EXPECT_EQ(lease("s/3")->holder, "");
}

TEST_P(Leases, AnExpiredLeasePassesToAnotherHolder) {
  ASSERT_EQ(store_->claim_leases({"site/a"}, "w1", 300ms, 1).size(), 1u);
  EXPECT_TRUE(store_->claim_leases({"site/a"}, "w2", 30s, 1).empty());
  std::this_thread::sleep_for(600ms);
  EXPECT_LE(lease("site/a")->remaining, 0ms);
  EXPECT_EQ(store_->claim_leases({"site/a"}, "w2", 30s, 1), (Names{"site/a"}));
  EXPECT_EQ(lease("site/a")->holder, "w2");
  EXPECT_EQ(lease("site/a")->generation, 2);
  // The old holder finds out when it renews.
  EXPECT_TRUE(store_->renew_leases("w1", 30s).empty());
}

TEST_P(Leases, RenewingKeepsALeaseAlive) {
  store_->claim_leases({"site/a", "site/b"}, "w1", 500ms, 2);
  for (int i = 0; i < 4; ++i) {
    std::this_thread::sleep_for(250ms);
    EXPECT_EQ(store_->renew_leases("w1", 500ms), (Names{"site/a", "site/b"}));
  }
  EXPECT_TRUE(store_->claim_leases({"site/a", "site/b"}, "w2", 30s, 2).empty());
}

TEST_P(Leases, ReleasedLeasesAreFreeAtOnce) {
  store_->claim_leases({"site/a", "site/b", "site/c"}, "w1", 30s, 3);
  store_->release_leases("w1", {"site/a"});
  store_->release_leases("w2");  // holds nothing: changes nothing
  EXPECT_EQ(lease("site/a")->holder, "");
  EXPECT_EQ(lease("site/b")->holder, "w1");
  store_->release_leases("w1");
  EXPECT_EQ(store_->claim_leases({"site/a", "site/b", "site/c"}, "w2", 30s, 3),
            (Names{"site/a", "site/b", "site/c"}));
}

TEST_P(Leases, ListingFiltersByPrefixAndLeavesTheLogAlone) {
  const std::int64_t seq = store_->last_seq();
  store_->claim_leases({"site/a", "worker/w1"}, "w1", 30s, 2);
  auto sites = store_->leases("site/");
  ASSERT_EQ(sites.size(), 1u);
  EXPECT_EQ(sites[0].name, "site/a");
  EXPECT_EQ(store_->leases().size(), 2u);
  EXPECT_EQ(store_->last_seq(), seq);
}

TEST_P(Leases, BadArgumentsAreRefused) {
  EXPECT_THROW(store_->claim_leases({"a"}, "", 30s, 1), StoreError);
  EXPECT_THROW(store_->claim_leases({"a"}, "w1", 0ms, 1), StoreError);
  EXPECT_THROW(store_->renew_leases("w1", -5ms), StoreError);
  EXPECT_TRUE(store_->leases().empty());
}

// Many workers claiming the same sites at once: every site ends with exactly
// one holder, and no claim returned a site that another claim also got.
TEST_P(Leases, ConcurrentClaimersNeverShareALease) {
  Names sites;
  for (int i = 0; i < 12; ++i) sites.push_back("site/" + std::to_string(i));
  constexpr int kWorkers = 4;
  std::vector<Names> got(kWorkers);
  std::vector<std::thread> threads;
  std::atomic<bool> go{false};
  for (int w = 0; w < kWorkers; ++w) {
    threads.emplace_back([&, w] {
      auto store = Store::open(url_);
      while (!go) std::this_thread::yield();
      for (int round = 0; round < 5; ++round) {
        Names held =
            store->claim_leases(sites, "w" + std::to_string(w), 30s, 3);
        got[w] = held;
      }
    });
  }
  go = true;
  for (auto& t : threads) t.join();
  std::set<std::string> seen;
  for (int w = 0; w < kWorkers; ++w) {
    EXPECT_LE(got[w].size(), 12u);
    for (const std::string& s : got[w]) EXPECT_TRUE(seen.insert(s).second) << s;
  }
  for (const Lease& l : store_->leases("site/")) {
    ASSERT_FALSE(l.holder.empty()) << l.name;
    const int w = std::stoi(l.holder.substr(1));
    EXPECT_NE(std::find(got[w].begin(), got[w].end(), l.name), got[w].end());
  }
}

INSTANTIATE_TEST_SUITE_P(Backends, Leases,
                         ::testing::Values("sqlite", "postgresql"),
                         [](const auto& info) { return info.param; });

}  // namespace
}  // namespace arscout::db
