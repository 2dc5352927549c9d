// The store's contract (store.h), checked identically on every backend.
#include <array>
#include <atomic>
#include <fstream>
#include <mutex>
#include <sstream>
#include <thread>

#include <gtest/gtest.h>
#include <libpq-fe.h>

#include "arscout/db/store.h"
#include "arscout/util/sha256.h"
#include "test_stores.h"

namespace arscout::db {
namespace {

using namespace std::chrono_literals;

class StoreConformance : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    ARSCOUT_FRESH_STORE_OR_SKIP(url_, GetParam());
    store_ = Store::open(url_);
  }

  // Runs fn, which must throw StoreError with `code`, and checks that the
  // store is unchanged afterwards.
  template <typename Fn>
  void expect_rejected(Fn fn, ErrorCode code, const std::string& says = "") {
    StoreStats before = store_->stats();
    try {
      fn();
      ADD_FAILURE() << "expected " << to_string(code) << ", nothing thrown";
    } catch (const StoreError& e) {
      EXPECT_EQ(e.code(), code) << e.what();
      if (!says.empty()) {
        EXPECT_NE(std::string(e.what()).find(says), std::string::npos)
            << e.what();
      }
    }
    StoreStats after = store_->stats();
    EXPECT_EQ(after.last_seq, before.last_seq);
    EXPECT_EQ(after.documents, before.documents);
    EXPECT_EQ(after.blobs, before.blobs);
  }

  std::string url_;
  std::unique_ptr<Store> store_;
};

// ---------------------------------------------------------------- documents

TEST_P(StoreConformance, PutThenGetReturnsEveryField) {
  WriteOp op = WriteOp::put("/captures/c1", "capture",
                            Json{{"status", "stored"}, {"n", 3}});
  op.author = "scout-7";
  WriteResult r = store_->write(op);
  EXPECT_EQ(r.path, "/captures/c1");
  EXPECT_EQ(r.version, 1);
  EXPECT_EQ(r.seq, 1);
  auto doc = store_->get("/captures/c1");
  ASSERT_TRUE(doc);
  EXPECT_EQ(doc->kind, "capture");
  EXPECT_EQ(doc->attrs, (Json{{"status", "stored"}, {"n", 3}}));
  EXPECT_EQ(doc->version, 1);
  EXPECT_EQ(doc->seq, 1);
  EXPECT_EQ(doc->author, "scout-7");
  EXPECT_GT(doc->created_us, 0);
  EXPECT_EQ(doc->created_us, doc->updated_us);
  EXPECT_FALSE(store_->get("/captures/none"));
}

TEST_P(StoreConformance, VersionsCountEveryWriteAndCreationTimeStays) {
  store_->put("/a", "thing", Json{{"v", 1}});
  std::this_thread::sleep_for(2ms);
  WriteResult r = store_->put("/a", "thing", Json{{"v", 2}});
  EXPECT_EQ(r.version, 2);
  EXPECT_EQ(r.seq, 2);
  auto doc = store_->get("/a");
  EXPECT_EQ(doc->attrs["v"], 2);
  EXPECT_LT(doc->created_us, doc->updated_us);
  EXPECT_EQ(store_->get("/a")->author, "arscout");  // the default author
}

TEST_P(StoreConformance, ExpectedVersionConflictNamesCurrentVersion) {
  store_->put("/sites/s1", "site", Json{{"state", "new"}}, 0);
  store_->put("/sites/s1", "site", Json{{"state", "two"}}, 1);
  expect_rejected([&] { store_->put("/sites/s1", "site", Json::object(), 0); },
                  ErrorCode::kConflict, "current is version 2");
  try {
    store_->put("/sites/s1", "site", Json::object(), 1);
    FAIL() << "stale write accepted";
  } catch (const ConflictError& e) {
    EXPECT_EQ(e.expected_version(), 1);
    EXPECT_EQ(e.current_version(), 2);
    EXPECT_EQ(e.path(), "/sites/s1");
  }
  expect_rejected(
      [&] { store_->put("/sites/none", "site", Json::object(), 4); },
      ErrorCode::kConflict, "current is absent");
  EXPECT_EQ(store_->get("/sites/s1")->attrs["state"], "two");
}

TEST_P(StoreConformance, MergePatchFollowsRfc7386) {
  store_->put("/d", "doc",
              Json{{"a", 1}, {"gone", true}, {"nested", {{"x", 1}, {"y", 2}}}});
  WriteResult r = store_->patch(
      "/d", Json{{"gone", nullptr}, {"b", "new"}, {"nested", {{"y", 3}}}}, 1);
  EXPECT_EQ(r.version, 2);
  auto doc = store_->get("/d");
  EXPECT_EQ(doc->attrs,
            (Json{{"a", 1}, {"b", "new"}, {"nested", {{"x", 1}, {"y", 3}}}}));
  EXPECT_EQ(doc->kind, "doc");
  expect_rejected(
      [&] {
        store_->patch("/d", Json{{"a", 9}}, 1);
      },
      ErrorCode::kConflict);
  expect_rejected(
      [&] {
        store_->patch("/missing", Json{{"a", 1}});
      },
      ErrorCode::kNotFound);
  expect_rejected([&] { store_->patch("/d", Json::array({1})); },
                  ErrorCode::kInvalidDocument);
}

TEST_P(StoreConformance, DeleteLeavesATombstoneAndVersionsContinue) {
  store_->put("/t", "doc", Json{{"k", 1}});
  WriteResult del = store_->remove("/t", 1);
  EXPECT_EQ(del.version, 2);
  EXPECT_FALSE(store_->get("/t"));
  auto log = store_->changes(0);
  ASSERT_EQ(log.size(), 2u);
  EXPECT_EQ(log[1].op, OpType::kDelete);
  EXPECT_EQ(log[1].version, 2);
  EXPECT_EQ(log[1].path, "/t");
  expect_rejected([&] { store_->remove("/t"); }, ErrorCode::kNotFound);
  WriteResult again = store_->put("/t", "doc", Json{{"k", 2}}, 0);
  EXPECT_EQ(again.version, 3);
  EXPECT_EQ(store_->get("/t")->attrs["k"], 2);
  EXPECT_EQ(store_->stats().documents, 1);
}

TEST_P(StoreConformance, BatchIsAllOrNothing) {
  store_->put("/b/existing", "doc", Json::object());
  std::vector<WriteOp> failing = {
      WriteOp::put("/b/one", "doc", Json{{"i", 1}}),
      WriteOp::patch("/b/existing", Json{{"touched", true}}),
      WriteOp::put("/b/existing", "doc", Json::object(), 7),  // conflict
  };
  expect_rejected([&] { store_->batch(failing); }, ErrorCode::kConflict);
  EXPECT_FALSE(store_->get("/b/one"));
  EXPECT_FALSE(store_->get("/b/existing")->attrs.contains("touched"));

  std::vector<WriteOp> invalid = {
      WriteOp::put("/b/two", "doc", Json::object()),
      WriteOp::put("/b/../x", "doc", Json::object())};
  expect_rejected([&] { store_->batch(invalid); }, ErrorCode::kInvalidPath,
                  "batch operation 1");

  std::vector<WriteOp> good = {WriteOp::put("/b/one", "doc", Json{{"i", 1}}),
                               WriteOp::put("/b/two", "doc", Json{{"i", 2}}),
                               WriteOp::remove("/b/existing")};
  auto results = store_->batch(good);
  ASSERT_EQ(results.size(), 3u);
  EXPECT_EQ(results[0].seq + 1, results[1].seq);
  EXPECT_EQ(results[1].seq + 1, results[2].seq);
  EXPECT_EQ(store_->stats().documents, 2);
}

// Concurrent callers are committed together (group commit); each batch must
// still win or lose on its own, losers leaving no trace.
TEST_P(StoreConformance, ConcurrentBatchesSucceedOrFailIndependently) {
  constexpr int kThreads = 8, kRounds = 30;
  for (int round = 0; round < kRounds; ++round) {
    std::string shared = "/race/" + std::to_string(round);
    std::atomic<int> winners{0}, conflicts{0};
    std::vector<std::thread> threads;
    for (int t = 0; t < kThreads; ++t) {
      threads.emplace_back([&, t] {
        std::string own = shared + "-t" + std::to_string(t);
        std::vector<WriteOp> ops = {
            WriteOp::put(own, "doc", Json{{"t", t}}),
            WriteOp::put(shared, "doc", Json{{"winner", t}}, 0)};
        // Every other thread also writes a lone document that must land.
        if (t % 2 == 0) store_->put(own + "-solo", "doc", Json::object());
        try {
          store_->batch(ops);
          ++winners;
        } catch (const ConflictError&) {
          ++conflicts;
        }
      });
    }
    for (auto& th : threads) th.join();
    ASSERT_EQ(winners.load(), 1) << "round " << round;
    ASSERT_EQ(conflicts.load(), kThreads - 1);
    int winner = store_->get(shared)->attrs["winner"];
    for (int t = 0; t < kThreads; ++t) {
      std::string own = shared + "-t" + std::to_string(t);
      EXPECT_EQ(store_->get(own).has_value(), t == winner) << own;
      EXPECT_EQ(store_->get(own + "-solo").has_value(), t % 2 == 0);
    }
  }
  auto log = store_->changes(0, "/**", 100000);
  EXPECT_EQ(log.size(), static_cast<std::size_t>(kRounds * (2 + kThreads / 2)));
  for (std::size_t i = 0; i < log.size(); ++i)
    ASSERT_EQ(log[i].seq, static_cast<std::int64_t>(i + 1));
}

TEST_P(StoreConformance, SubtreeAndChildrenRespectDepth) {
  for (const char* p :
       {"/sites", "/sites/s1", "/sites/s1/model", "/sites/s1/model/sparse",
        "/sites/s2", "/sitesX", "/other"})
    store_->put(p, "doc", Json::object());
  auto paths = [](const std::vector<Document>& docs) {
    std::vector<std::string> out;
    for (const auto& d : docs) out.push_back(d.path);
    return out;
  };
  EXPECT_EQ(paths(store_->get_subtree("/sites", 0)),
            std::vector<std::string>{"/sites"});
  EXPECT_EQ(paths(store_->get_subtree("/sites", 1)),
            (std::vector<std::string>{"/sites", "/sites/s1", "/sites/s2"}));
  EXPECT_EQ(paths(store_->get_subtree("/sites", 5)),
            (std::vector<std::string>{"/sites", "/sites/s1", "/sites/s1/model",
                                      "/sites/s1/model/sparse", "/sites/s2"}));
  EXPECT_EQ(store_->get_subtree("/", 16).size(), 7u);
  EXPECT_EQ(paths(store_->list_children("/sites")),
            (std::vector<std::string>{"/sites/s1", "/sites/s2"}));
  EXPECT_EQ(store_->list_children("/").size(), 3u);
}

TEST_P(StoreConformance, QueriesByPattern) {
  for (const char* p :
       {"/captures", "/captures/c1", "/captures/c2", "/captures/c2/thumb",
        "/sites/s1/model", "/sites/s2/model", "/sites/s2/other"})
    store_->put(p, "doc", Json::object());
  auto count = [&](const std::string& pattern) {
    Query q;
    q.pattern = pattern;
    return store_->query(q).size();
  };
  EXPECT_EQ(count("/captures/*"), 2u);
  EXPECT_EQ(count("/sites/*/model"), 2u);
  EXPECT_EQ(count("/captures/**"), 4u);
  EXPECT_EQ(count("/**"), 7u);
  EXPECT_EQ(count("/captures/c2/thumb"), 1u);
  Query limited;
  limited.pattern = "/**";
  limited.limit = 3;
  auto docs = store_->query(limited);
  ASSERT_EQ(docs.size(), 3u);
  EXPECT_EQ(docs[0].path, "/captures");
}

TEST_P(StoreConformance, QueriesByAttributeEquality) {
  store_->put("/captures/a", "capture",
              Json{{"status", "registered"},
                   {"gps", {{"satellites", 8}}},
                   {"ok", true}});
  store_->put("/captures/b", "capture",
              Json{{"status", "rejected"}, {"gps", {{"satellites", 8}}}});
  store_->put("/captures/c", "capture",
              Json{{"status", "registered"}, {"gps", {{"satellites", 4}}}});
  store_->put("/sites/x", "site", Json{{"status", "registered"}});
  Query q;
  q.pattern = "/captures/*";
  q.equals = {{"status", "registered"}};
  EXPECT_EQ(store_->query(q).size(), 2u);
  q.equals.push_back({"gps.satellites", 8});
  auto docs = store_->query(q);
  ASSERT_EQ(docs.size(), 1u);
  EXPECT_EQ(docs[0].path, "/captures/a");
  q.equals = {{"ok", true}};
  EXPECT_EQ(store_->query(q).size(), 1u);
  q.equals = {{"gps", Json{{"satellites", 4}}}};
  EXPECT_EQ(store_->query(q).size(), 1u);
  q.equals = {{"bad key!", 1}};
  EXPECT_THROW(store_->query(q), StoreError);
}

TEST_P(StoreConformance, QueriesByGeographicRadius) {
  // Offsets north of a centre in Graz: 1 degree of latitude ~ 111.2 km.
  const double lat0 = 47.0707, lon0 = 15.4395;
  auto put_at = [&](const std::string& path, double north_m) {
    store_->put(
        path, "capture",
        Json{{"gps", {{"lat", lat0 + north_m / 111195.0}, {"lon", lon0}}}});
  };
  put_at("/captures/m10", 10);
  put_at("/captures/m40", 40);
  put_at("/captures/m60", 60);
  put_at("/captures/km5", 5000);
  store_->put("/captures/nogps", "capture", Json{{"x", 1}});
  Query q;
  q.pattern = "/captures/*";
  q.near = GeoRadius{lat0, lon0, 50};
  auto docs = store_->query(q);
  ASSERT_EQ(docs.size(), 2u);
  EXPECT_EQ(docs[0].path, "/captures/m10");
  EXPECT_EQ(docs[1].path, "/captures/m40");
  q.near->radius_m = 6000;
  EXPECT_EQ(store_->query(q).size(), 4u);
  q.near = GeoRadius{95, 0, 10};
  EXPECT_THROW(store_->query(q), StoreError);
}

TEST_P(StoreConformance, RejectsBadInputAndChangesNothing) {
  store_->put("/keep", "doc", Json{{"v", 1}});
  expect_rejected([&] { store_->put("/a/../b", "doc", Json::object()); },
                  ErrorCode::kInvalidPath, "'..'");
  expect_rejected([&] { store_->put("/a", "doc", Json::array()); },
                  ErrorCode::kInvalidDocument, "JSON object");
  expect_rejected([&] { store_->put("/a", "bad kind", Json::object()); },
                  ErrorCode::kInvalidDocument, "kind");
  expect_rejected(
      [&] {
        store_->put("/a", "doc",
                    Json{{"big", std::string(kMaxAttributesBytes, 'x')}});
      },
      ErrorCode::kTooLarge, "over the limit");
  WriteOp unknown = WriteOp::put("/a", "doc", Json::object());
  unknown.blobs = BlobRefs{{"image", std::string(64, 'a')}};
  expect_rejected([&] { store_->write(unknown); }, ErrorCode::kUnknownBlob,
                  "not stored");
  unknown.blobs = BlobRefs{{"image", "not-a-hash"}};
  expect_rejected([&] { store_->write(unknown); }, ErrorCode::kInvalidDocument,
                  "hex");
  expect_rejected([&] { store_->put("/keep", "doc", Json::object(), -2); },
                  ErrorCode::kInvalidArgument);
  expect_rejected(
      [&] {
        store_->put("/a", "doc", Json{{"s", std::string("\xff\xfe")}});
      },
      ErrorCode::kInvalidDocument, "cannot be stored");
  EXPECT_EQ(store_->get("/keep")->attrs["v"], 1);
  EXPECT_THROW(store_->get("/bad path"), StoreError);
  EXPECT_THROW(store_->changes(0, "/a*"), StoreError);
}

// -------------------------------------------------------------------- blobs

// Streams `size` pseudo-random bytes without holding them.
class GeneratedBuffer : public std::streambuf {
 public:
  explicit GeneratedBuffer(std::int64_t size) : left_(size) {}

 protected:
  int_type underflow() override {
    if (left_ == 0) return traits_type::eof();
    std::size_t n = std::min<std::int64_t>(left_, buf_.size());
    for (std::size_t i = 0; i < n; ++i) {
      state_ = state_ * 6364136223846793005ULL + 1442695040888963407ULL;
      buf_[i] = static_cast<char>(state_ >> 56);
    }
    left_ -= n;
    setg(buf_.data(), buf_.data(), buf_.data() + n);
    return traits_type::to_int_type(buf_[0]);
  }

 private:
  std::int64_t left_;
  std::uint64_t state_ = 42;
  std::array<char, 65536> buf_{};
};

// Counts and checksums what is written to it, keeping nothing.
class CountingBuffer : public std::streambuf {
 public:
  std::int64_t count = 0;
  std::uint64_t checksum = 0;

 protected:
  std::streamsize xsputn(const char* s, std::streamsize n) override {
    for (std::streamsize i = 0; i < n; ++i)
      checksum = checksum * 31 + static_cast<unsigned char>(s[i]);
    count += n;
    return n;
  }
  int_type overflow(int_type c) override {
    if (c != traits_type::eof()) {
      char ch = static_cast<char>(c);
      xsputn(&ch, 1);
    }
    return c;
  }
};

TEST_P(StoreConformance, BlobsAreContentAddressedAndStoredOnce) {
  std::string h1 = store_->put_blob("abc");
  EXPECT_EQ(h1,
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(store_->put_blob(std::string("abc")), h1);
  EXPECT_EQ(store_->stats().blobs, 1);
  EXPECT_EQ(store_->get_blob(h1), "abc");
  EXPECT_EQ(store_->blob_info(h1)->size, 3);
  std::string empty = store_->put_blob("");
  EXPECT_EQ(store_->get_blob(empty), "");
  EXPECT_FALSE(store_->blob_info(std::string(64, '0')));
  std::ostringstream out;
  expect_rejected([&] { store_->read_blob(std::string(64, '0'), out); },
                  ErrorCode::kUnknownBlob);
  expect_rejected([&] { store_->read_blob(h1, out, 2, 5); },
                  ErrorCode::kInvalidArgument, "past the end");
  EXPECT_THROW(store_->blob_info("xyz"), StoreError);
}

// Bytes in hand, several at once (the engine state's parts): the same
// hashes as one at a time, chunk boundaries and empty blobs included, a
// blob already stored and one repeated in the batch kept once, and one
// over a transaction's share (8 MiB) staged as a stream.
TEST_P(StoreConformance, BlobsPutTogetherReadBackAsPutAlone) {
  const std::string chunk_and_a_bit((1 << 20) + 7, 'c');
  std::string large(9 << 20, '\0');
  for (size_t i = 0; i < large.size(); ++i)
    large[i] = static_cast<char>((i * 2654435761u) >> 13);
  const std::string before = store_->put_blob("stored before");
  const std::vector<std::string_view> blobs = {
      "one", "", chunk_and_a_bit, "stored before", "one", large};
  const std::vector<std::string> shas = store_->put_blobs(blobs);
  ASSERT_EQ(shas.size(), blobs.size());
  EXPECT_EQ(shas[3], before);
  EXPECT_EQ(shas[0], shas[4]);
  for (size_t i = 0; i < blobs.size(); ++i) {
    EXPECT_EQ(shas[i], util::sha256_hex(blobs[i])) << i;
    EXPECT_EQ(store_->get_blob(shas[i]), blobs[i]) << i;
    EXPECT_EQ(store_->blob_info(shas[i])->size,
              static_cast<std::int64_t>(blobs[i].size()));
  }
  EXPECT_EQ(store_->stats().blobs, 5);
  std::ostringstream slice;
  store_->read_blob(shas[2], slice, (1 << 20) - 2, 6);
  EXPECT_EQ(slice.str(), "cccccc");
  EXPECT_TRUE(store_->put_blobs({}).empty());
}

TEST_P(StoreConformance, LargeBlobStreamsAndReadsRanges) {
  const std::int64_t size = 64LL * 1024 * 1024 + 12345;  // > 64 MB, uneven
  GeneratedBuffer gen(size);
  std::istream in(&gen);
  std::string hash = store_->put_blob(in);
  EXPECT_EQ(store_->blob_info(hash)->size, size);

  GeneratedBuffer again(size);
  CountingBuffer expected_sink, actual_sink;
  std::ostream expected_out(&expected_sink), actual_out(&actual_sink);
  expected_out << &again;
  store_->read_blob(hash, actual_out);
  EXPECT_EQ(actual_sink.count, size);
  EXPECT_EQ(actual_sink.checksum, expected_sink.checksum);

  // A range across a chunk boundary equals the same slice of the whole.
  std::ostringstream slice;
  const std::int64_t offset = (1 << 20) - 100;
  store_->read_blob(hash, slice, offset, 300);
  GeneratedBuffer third(size);
  std::istream reread(&third);
  reread.ignore(offset);
  std::string want(300, '\0');
  reread.read(want.data(), 300);
  EXPECT_EQ(slice.str(), want);
  EXPECT_EQ(store_->stats().blobs, 1);
}

TEST_P(StoreConformance, GarbageCollectionKeepsReferencedBlobs) {
  std::string used = store_->put_blob("used by a document");
  std::string orphan = store_->put_blob("nobody refers to me");
  WriteOp op = WriteOp::put("/captures/c1", "capture", Json::object());
  op.blobs = BlobRefs{{"image", used}};
  store_->write(op);
  EXPECT_EQ(store_->collect_garbage(3600s), 0u);  // within the grace period
  EXPECT_EQ(store_->collect_garbage(0s), 1u);
  EXPECT_FALSE(store_->blob_info(orphan));
  EXPECT_EQ(store_->get_blob(used), "used by a document");
  EXPECT_EQ(store_->get("/captures/c1")->blobs.at("image"), used);
  store_->remove("/captures/c1");
  EXPECT_EQ(store_->collect_garbage(0s), 1u);
  EXPECT_FALSE(store_->blob_info(used));
}

// --------------------------------------------------------------- change log

TEST_P(StoreConformance, ChangeLogIsOrderedFilteredAndResumable) {
  for (int i = 0; i < 10; ++i)
    store_->put("/captures/c" + std::to_string(i), "capture", Json{{"i", i}});
  store_->put("/sites/s1", "site", Json::object());
  store_->patch("/captures/c3", Json{{"seen", true}});
  auto all = store_->changes(0);
  ASSERT_EQ(all.size(), 12u);
  for (std::size_t i = 0; i < all.size(); ++i)
    EXPECT_EQ(all[i].seq, static_cast<std::int64_t>(i + 1));
  EXPECT_EQ(all[11].op, OpType::kPatch);
  EXPECT_EQ(all[11].version, 2);
  EXPECT_EQ(all[10].kind, "site");

  auto first = store_->changes(0, "/captures/*", 5);
  ASSERT_EQ(first.size(), 5u);
  auto rest = store_->changes(first.back().seq, "/captures/*");
  ASSERT_EQ(rest.size(), 6u);
  EXPECT_EQ(rest.back().path, "/captures/c3");
  EXPECT_EQ(store_->changes(0, "/sites/**").size(), 1u);
  EXPECT_EQ(store_->last_seq(), 12);
}

TEST_P(StoreConformance, SubscriberGetsBacklogThenLiveChangesInOrder) {
  store_->put("/captures/early", "capture", Json::object());
  store_->put("/sites/ignored", "site", Json::object());
  std::mutex mu;
  std::vector<Change> seen;
  auto sub = store_->subscribe("/captures/*", 0, [&](const Change& c) {
    std::lock_guard lock(mu);
    seen.push_back(c);
  });
  for (int i = 0; i < 20; ++i)
    store_->put("/captures/live" + std::to_string(i), "capture",
                Json::object());
  auto deadline = std::chrono::steady_clock::now() + 10s;
  while (std::chrono::steady_clock::now() < deadline) {
    {
      std::lock_guard lock(mu);
      if (seen.size() >= 21) break;
    }
    std::this_thread::sleep_for(5ms);
  }
  sub->stop();
  std::lock_guard lock(mu);
  ASSERT_EQ(seen.size(), 21u);
  EXPECT_EQ(seen[0].path, "/captures/early");
  for (std::size_t i = 1; i < seen.size(); ++i)
    EXPECT_LT(seen[i - 1].seq, seen[i].seq);
  EXPECT_EQ(sub->last_seq(), seen.back().seq);
}

TEST_P(StoreConformance, SubscriberResumesFromItsCheckpoint) {
  for (int i = 0; i < 5; ++i)
    store_->put("/e/" + std::to_string(i), "doc", Json::object());
  std::atomic<std::int64_t> last{0};
  {
    auto sub = store_->subscribe("/e/*", store_->load_checkpoint("w"),
                                 [&](const Change& c) { last = c.seq; });
    auto deadline = std::chrono::steady_clock::now() + 10s;
    while (last < 5 && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(5ms);
  }
  store_->save_checkpoint("w", last);
  EXPECT_EQ(store_->load_checkpoint("w"), 5);
  EXPECT_EQ(store_->load_checkpoint("never"), 0);
  for (int i = 5; i < 8; ++i)
    store_->put("/e/" + std::to_string(i), "doc", Json::object());
  auto missed = store_->changes(store_->load_checkpoint("w"), "/e/*");
  ASSERT_EQ(missed.size(), 3u);
  EXPECT_EQ(missed.front().path, "/e/5");
}

TEST_P(StoreConformance, CallbackErrorStopsTheSubscriptionAndIsReported) {
  store_->put("/x/1", "doc", Json::object());
  auto sub = store_->subscribe("/**", 0, [](const Change&) {
    throw std::runtime_error("consumer broke");
  });
  auto deadline = std::chrono::steady_clock::now() + 10s;
  while (sub->error().empty() && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(5ms);
  EXPECT_NE(sub->error().find("consumer broke"), std::string::npos);
  EXPECT_EQ(sub->last_seq(), 0);
}

// ---------------------------------------------------------- open and schema

TEST_P(StoreConformance, ReopeningKeepsDataAndSchema) {
  store_->put("/persist", "doc", Json{{"v", 42}});
  std::string blob = store_->put_blob("kept");
  store_.reset();
  auto reopened = Store::open(url_);
  EXPECT_EQ(reopened->get("/persist")->attrs["v"], 42);
  EXPECT_EQ(reopened->get_blob(blob), "kept");
  EXPECT_EQ(reopened->schema_versions(), (std::vector<int>{1, 2}));
  EXPECT_EQ(reopened->last_seq(), 1);
  EXPECT_EQ(reopened->backend(), GetParam());
}

INSTANTIATE_TEST_SUITE_P(Backends, StoreConformance,
                         ::testing::Values("sqlite", "postgresql"),
                         [](const auto& info) { return info.param; });

// ------------------------------------------------------------ open failures

TEST(StoreOpen, RejectsUnknownSchemes) {
  try {
    Store::open("mysql://localhost/x");
    FAIL();
  } catch (const StoreError& e) {
    EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument);
    EXPECT_NE(std::string(e.what()).find("sqlite:"), std::string::npos);
  }
  EXPECT_THROW(Store::open("sqlite:"), StoreError);
}

TEST(StoreOpen, ReportsUnopenableDatabasesAsUnavailable) {
  for (const char* url : {"sqlite:/nonexistent-dir/x/store.db",
                          "postgresql://nobody@127.0.0.1:1/none"}) {
    try {
      Store::open(url);
      ADD_FAILURE() << "opened " << url;
    } catch (const StoreError& e) {
      EXPECT_EQ(e.code(), ErrorCode::kUnavailable) << url;
    }
  }
}

TEST(StoreOpen, RejectsAFileThatIsNotADatabase) {
  std::string dir = testing::make_temp_dir("notdb");
  {
    std::ofstream f(dir + "/junk.db");
    f << std::string(4096, 'j');
  }
  try {
    Store::open("sqlite:" + dir + "/junk.db");
    FAIL();
  } catch (const StoreError& e) {
    EXPECT_EQ(e.code(), ErrorCode::kUnavailable);
  }
}

}  // namespace
}  // namespace arscout::db

namespace arscout::db {
namespace {

// PostgreSQL-only behaviour: index use and surviving lost connections.
class PostgresStore : public ::testing::Test {
 protected:
  void SetUp() override {
    ARSCOUT_FRESH_STORE_OR_SKIP(url_, "postgresql");
    store_ = Store::open(url_);
  }
  // Runs one statement as the fixture's superuser (test plumbing only).
  void admin(const std::string& sql) {
    PGconn* conn = PQconnectdb(url_.c_str());
    PGresult* res = PQexec(conn, sql.c_str());
    ExecStatusType st = PQresultStatus(res);
    EXPECT_TRUE(st == PGRES_COMMAND_OK || st == PGRES_TUPLES_OK)
        << PQerrorMessage(conn);
    PQclear(res);
    PQfinish(conn);
  }
  std::string url_;
  std::unique_ptr<Store> store_;
};

TEST_F(PostgresStore, RadiusQueryIsServedByThePositionIndex) {
  std::vector<WriteOp> ops;
  for (int i = 0; i < 4000; ++i)
    ops.push_back(WriteOp::put(
        "/captures/c" + std::to_string(i), "capture",
        Json{{"gps",
              {{"lat", -60 + (i % 200) * 0.6}, {"lon", -170 + i * 0.085}}}}));
  store_->batch(ops);
  admin("ANALYZE documents");
  Query q;
  q.pattern = "/captures/*";
  q.near = GeoRadius{10.0, 20.0, 1000};
  std::string plan = store_->explain(q);
  EXPECT_NE(plan.find("documents_by_position"), std::string::npos) << plan;
  EXPECT_EQ(plan.find("Seq Scan"), std::string::npos) << plan;
}

TEST_F(PostgresStore, RecoversFromKilledConnectionsAndSubscribersCatchUp) {
  std::atomic<std::int64_t> seen{0};
  std::atomic<int> count{0};
  auto sub = store_->subscribe("/**", 0, [&](const Change& c) {
    seen = c.seq;
    ++count;
  });
  for (int i = 0; i < 5; ++i)
    store_->put("/k/" + std::to_string(i), "doc", Json::object());
  // Kill every other connection to this database, the pool's and LISTEN's.
  admin(
      "SELECT pg_terminate_backend(pid) FROM pg_stat_activity WHERE "
      "datname = current_database() AND pid <> pg_backend_pid()");
  // Dead pooled connections are replaced without the caller noticing.
  for (int i = 5; i < 10; ++i)
    EXPECT_NO_THROW(
        store_->put("/k/" + std::to_string(i), "doc", Json::object()));
  EXPECT_EQ(store_->get_subtree("/k", 1).size(), 10u);
  auto deadline = std::chrono::steady_clock::now() + 15s;
  while (count < 10 && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(10ms);
  EXPECT_EQ(count.load(), 10);
  EXPECT_EQ(seen.load(), store_->last_seq());
}

}  // namespace
}  // namespace arscout::db
