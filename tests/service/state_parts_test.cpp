// The engine state in content-defined parts (engine/service/src/state_parts.h):
// the parts join back to the bytes, and an edit changes only the parts
// around it, so the store writes a bounded share of a grown state.
#include "state_parts.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <random>
#include <set>

#include "arscout/db/store.h"
#include "test_stores.h"

namespace arscout::engine::service {
namespace {

std::string random_bytes(size_t n, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::string bytes(n, '\0');
  for (size_t i = 0; i < n; i += 8) {
    const std::uint64_t word = rng();
    std::memcpy(bytes.data() + i, &word, std::min<size_t>(8, n - i));
  }
  return bytes;
}

std::string joined(const std::vector<std::string_view>& parts) {
  std::string bytes;
  for (std::string_view part : parts) bytes += part;
  return bytes;
}

// How many parts of `after` are not among the parts of `before`.
size_t new_parts(std::string_view before, std::string_view after) {
  std::set<std::string_view> old;
  for (std::string_view part : cut_state_parts(before)) old.insert(part);
  size_t fresh = 0;
  for (std::string_view part : cut_state_parts(after))
    fresh += old.count(part) ? 0 : 1;
  return fresh;
}

TEST(StateParts, PartsJoinBackAndStayWithinTheirBounds) {
  EXPECT_TRUE(cut_state_parts("").empty());
  const std::string small = random_bytes(1000, 1);
  ASSERT_EQ(cut_state_parts(small).size(), 1u);
  const std::string big = random_bytes(14 << 20, 2);
  const std::vector<std::string_view> parts = cut_state_parts(big);
  EXPECT_EQ(joined(parts), big);
  EXPECT_GT(parts.size(), 20u);  // about 3 x 64 KiB on average
  EXPECT_LE(parts.size(), kMaxStateParts);
  for (size_t i = 0; i + 1 < parts.size(); ++i) {
    EXPECT_GE(parts[i].size(), size_t{64 << 10});
    EXPECT_LE(parts[i].size(), size_t{512 << 10});
  }
  // A state far larger (64 KiB parts would be 1,024) still fits the blob
  // references a document allows.
  const std::string huge = random_bytes(64 << 20, 3);
  EXPECT_LE(cut_state_parts(huge).size(), kMaxStateParts);
}

TEST(StateParts, AnEditChangesOnlyThePartsAroundIt) {
  const std::string before = random_bytes(14 << 20, 4);
  const size_t total = cut_state_parts(before).size();
  std::string overwritten = before;  // a camera's pose moved
  overwritten[7 << 20] ^= 0x5a;
  EXPECT_EQ(new_parts(before, overwritten), 1u);
  std::string inserted = before;  // a new pair of images in the middle
  inserted.insert(5 << 20, random_bytes(30000, 5));
  EXPECT_LE(new_parts(before, inserted), 2u);
  std::string grown = before;  // a new image's records at the end
  grown += random_bytes(70000, 6);
  EXPECT_LE(new_parts(before, grown), 2u);
  EXPECT_GT(total, 20u);
}

void put_engine_doc(db::Store& store, const std::string& path,
                    db::BlobRefs refs) {
  db::WriteOp op = db::WriteOp::put(path, "engine-state", db::Json::object());
  op.blobs = std::move(refs);
  store.write(op);
}

TEST(StateParts, ReadBackFromPartsOrFromTheOneBlobOfOldDocuments) {
  auto store = db::Store::open(arscout::testing::fresh_sqlite_url());
  const std::string bytes = random_bytes(3 << 20, 7);
  db::BlobRefs refs;
  const std::vector<std::string_view> parts = cut_state_parts(bytes);
  for (size_t i = 0; i < parts.size(); ++i)
    refs[state_part_name(i)] = store->put_blob(parts[i]);
  ASSERT_GT(refs.size(), 1u);
  put_engine_doc(*store, "/sites/s/engine", refs);
  EXPECT_EQ(read_state_bytes(*store, *store->get("/sites/s/engine")), bytes);
  put_engine_doc(*store, "/sites/t/engine",
                 {{"state", store->put_blob(bytes)}});
  EXPECT_EQ(read_state_bytes(*store, *store->get("/sites/t/engine")), bytes);
  put_engine_doc(*store, "/sites/u/engine", {});
  EXPECT_FALSE(read_state_bytes(*store, *store->get("/sites/u/engine")));
}

}  // namespace
}  // namespace arscout::engine::service
