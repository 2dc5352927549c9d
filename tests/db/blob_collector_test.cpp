// The blob collector (db/blob_collector.h, issue 37): unreferenced blobs
// past the grace period go by themselves, referenced ones and new ones
// stay, a blob stored again counts as new, and the counters say what went.
// On both backends.
#include <chrono>
#include <thread>

#include <gtest/gtest.h>

#include "arscout/db/blob_collector.h"
#include "arscout/db/store.h"
#include "store_fixture.h"

namespace arscout::db {
namespace {

using namespace std::chrono_literals;

using BlobCollectorTest = ::arscout::testing::FreshStoreTest;

TEST_P(BlobCollectorTest, UnreferencedBlobsPastTheGraceGoAndTheRestStays) {
  const std::string orphan = store_->put_blob(std::string(3000, 'o'));
  const std::string kept = store_->put_blob(std::string(2000, 'k'));
  WriteOp op = WriteOp::put("/sites/s1/model", "model", Json::object());
  op.blobs = BlobRefs{{"sparse", kept}};
  store_->write(op);
  BlobCollector collector(*store_, {0s, 1s});
  EXPECT_EQ(collector.collect_now(), 0u);  // both younger than 1 s
  std::this_thread::sleep_for(1100ms);
  // Stored again just before the collection: new again, so a writer that
  // refers to it next finds it.
  const std::string again = store_->put_blob(std::string(1000, 'a'));
  std::this_thread::sleep_for(1100ms);
  EXPECT_EQ(store_->put_blob(std::string(1000, 'a')), again);
  EXPECT_EQ(collector.collect_now(), 1u);
  EXPECT_FALSE(store_->blob_info(orphan));
  EXPECT_TRUE(store_->blob_info(kept));
  EXPECT_TRUE(store_->blob_info(again));
  const BlobCollectorStats s = collector.stats();
  EXPECT_EQ(s.runs, 2);
  EXPECT_EQ(s.blobs_removed, 1);
  EXPECT_GE(s.bytes_removed, 3000);
  EXPECT_EQ(s.blobs, 2);
  const std::string metrics = collector.metrics();
  EXPECT_NE(metrics.find("arscout_gc_runs_total 2"), std::string::npos)
      << metrics;
  EXPECT_NE(metrics.find("arscout_gc_blobs_removed_total 1"),
            std::string::npos);
}

TEST_P(BlobCollectorTest, ItRunsByItselfEveryInterval) {
  store_->put_blob(std::string(100, 'x'));
  BlobCollector collector(*store_, {1s, 0s});
  collector.start();
  for (int i = 0; i < 50 && collector.stats().blobs_removed == 0; ++i)
    std::this_thread::sleep_for(100ms);
  collector.stop();
  EXPECT_GE(collector.stats().runs, 1);
  EXPECT_EQ(collector.stats().blobs_removed, 1);
  EXPECT_EQ(store_->stats().blobs, 0);
}

INSTANTIATE_TEST_SUITE_P(Backends, BlobCollectorTest,
                         ::testing::Values("sqlite", "postgresql"),
                         [](const auto& info) { return info.param; });

}  // namespace
}  // namespace arscout::db
