// BlobWriter: blobs stored off the caller's thread, in order, each future
// giving the blob's hash.
#include "blob_writer.h"

#include <gtest/gtest.h>

#include <future>
#include <string>
#include <vector>

#include "arscout/db/store.h"
#include "arscout/util/sha256.h"
#include "test_stores.h"

namespace arscout::engine::service {
namespace {

TEST(BlobWriter, StoresEveryBlobAndGivesItsHash) {
  auto store = db::Store::open(arscout::testing::fresh_sqlite_url());
  BlobWriter writer(*store);
  std::vector<std::string> blobs;
  std::vector<std::shared_future<std::string>> shas;
  for (int i = 0; i < 20; ++i) {
    blobs.push_back(std::string(1000 + 70000 * i, static_cast<char>('a' + i)));
    shas.push_back(writer.put(blobs.back()));
  }
  for (size_t i = 0; i < blobs.size(); ++i) {
    EXPECT_EQ(shas[i].get(), util::sha256_hex(blobs[i]));
    EXPECT_EQ(store->get_blob(shas[i].get()), blobs[i]);
  }
  // The thread ends when the queue is empty and starts again with work.
  EXPECT_EQ(writer.put("later").get(), util::sha256_hex("later"));
}

TEST(BlobWriter, DestroyedWithWorkQueuedEndsCleanly) {
  auto store = db::Store::open(arscout::testing::fresh_sqlite_url());
  std::vector<std::shared_future<std::string>> shas;
  {
    BlobWriter writer(*store);
    for (int i = 0; i < 50; ++i)
      shas.push_back(writer.put(std::string(200000, static_cast<char>(i))));
  }
  // Blobs are written in order, so the stored ones come first; how many
  // depends on how far the thread got before the destructor (under
  // valgrind, none).
  int stored = 0, dropped = 0;
  for (auto& sha : shas) {
    try {
      const std::string hash = sha.get();
      EXPECT_EQ(dropped, 0) << "a blob stored after one that was dropped";
      EXPECT_TRUE(store->blob_info(hash));
      ++stored;
    } catch (const std::future_error& e) {
      EXPECT_EQ(e.code(), std::future_errc::broken_promise);
      ++dropped;
    }
  }
  EXPECT_EQ(stored + dropped, 50);
}

}  // namespace
}  // namespace arscout::engine::service
