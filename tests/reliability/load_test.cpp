// Load: 8 scouts upload 30 captures each at once to `arscout serve` (its own
// process), on SQLite and on PostgreSQL. Half the captures first suffer an
// interrupted attempt (cut or reset mid-body, or an answer that never
// arrives) and are retried. Exactly one capture per upload must be stored,
// byte for byte, with one change each, and the server's peak resident
// memory must stay within a bound. ARSCOUT_LOAD_SCOUTS and
// ARSCOUT_LOAD_CAPTURES scale it (the `long` label runs 8 x 250).
#include <chrono>
#include <cstdlib>
#include <iomanip>
#include <iostream>
#include <mutex>
#include <random>
#include <thread>

#include <gtest/gtest.h>

#include "arscout/db/store.h"
#include "arscout/http/client.h"
#include "arscout/ingest/auth.h"
#include "flaky_upload.h"
#include "serve_process.h"
#include "test_stores.h"

namespace arscout {
namespace {

using Json = nlohmann::json;
using namespace std::chrono_literals;

int env_int(const char* name, int fallback) {
  const char* value = std::getenv(name);
  return value != nullptr ? std::atoi(value) : fallback;
}

// The server may hold a few bodies per connection and SQLite or libpq
// caches; far less than this unless something accumulates per request.
constexpr std::int64_t kPeakRssBoundKib = 512 * 1024;

// In the scout's own id space ("{token name}.{id}"), kept as it is.
std::string capture_id(int scout, int i) {
  return "scout" + std::to_string(scout) + "." + std::to_string(i);
}

std::string metadata_for(int scout, int i) {
  return Json{{"capture_id", capture_id(scout, i)},
              {"gps",
               {{"lat", 48.2 + 0.001 * scout},
                {"lon", 16.37 + 0.0001 * i},
                {"h_acc", 4.0}}}}
      .dump();
}

struct ScoutTally {
  int interrupted = 0, replays = 0, retries = 0;
  std::vector<std::string> failures, retry_reasons;
};

struct LoadReport {
  std::int64_t half_rss_kib = 0;
  double seconds = 0;
  ScoutTally total;
};

class LoadTest : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    ARSCOUT_FRESH_STORE_OR_SKIP(url_, GetParam());
    store_ = db::Store::open(url_);
    dir_ = testing::make_temp_dir("load");
    scouts_ = env_int("ARSCOUT_LOAD_SCOUTS", 8);
    captures_ = env_int("ARSCOUT_LOAD_CAPTURES", 30);
    for (int s = 0; s < scouts_; ++s)
      tokens_.push_back(ingest::create_token(*store_, ingest::Role::kScout,
                                             "scout" + std::to_string(s)));
  }

  std::string photo(int scout, int i) {
    return testing::noise_jpeg(scout * 100000 + i, 480, 360);
  }

  ScoutTally run_scout(const testing::ServeProcess& server, int s,
                       std::atomic<int>* done) {
    ScoutTally tally;
    http::ClientOptions options;
    options.server = server.url();
    options.token = tokens_[s];
    options.timeout = 30s;
    http::Client client(options);
    std::mt19937 rng(static_cast<unsigned>(s));
    std::uniform_real_distribution<double> fraction(0.05, 0.95);
    for (int i = 0; i < captures_; ++i) {
      std::string jpeg = photo(s, i), meta = metadata_for(s, i);
      auto how = testing::interruption_for(s, i);
      tally.interrupted += how != testing::Interruption::kNone;
      testing::interrupted_upload(testing::port_of(server.url()), tokens_[s],
                                  meta, jpeg, how, fraction(rng));
      auto out = testing::upload_until_stored(client, meta, jpeg);
      if (out.status != 201)
        tally.failures.push_back(capture_id(s, i) + ": " +
                                 std::to_string(out.status) + " " + out.body);
      tally.replays += out.replay;
      tally.retries += out.retries;
      for (auto& reason : out.retry_reasons)
        tally.retry_reasons.push_back(capture_id(s, i) + ": " + reason);
      ++*done;
    }
    return tally;
  }

  LoadReport run_scouts(const testing::ServeProcess& server) {
    LoadReport report;
    std::vector<ScoutTally> tallies(scouts_);
    std::vector<std::thread> threads;
    std::atomic<int> done{0};
    auto start = std::chrono::steady_clock::now();
    for (int s = 0; s < scouts_; ++s)
      threads.emplace_back(
          [&, s] { tallies[s] = run_scout(server, s, &done); });
    // The resident set half way, to compare with the end: bounded memory
    // does not keep growing with the number of uploads.
    while (done < scouts_ * captures_ / 2) std::this_thread::sleep_for(10ms);
    report.half_rss_kib = server.rss_kib();
    for (auto& t : threads) t.join();
    report.seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
            .count();
    for (const auto& t : tallies) {
      report.total.interrupted += t.interrupted;
      report.total.replays += t.replays;
      report.total.retries += t.retries;
      report.total.failures.insert(report.total.failures.end(),
                                   t.failures.begin(), t.failures.end());
      report.total.retry_reasons.insert(report.total.retry_reasons.end(),
                                        t.retry_reasons.begin(),
                                        t.retry_reasons.end());
    }
    return report;
  }

  // Every upload stored once, byte for byte; returns the number missing.
  int check_store_holds_every_capture() {
    int missing = 0;
    for (int s = 0; s < scouts_; ++s)
      for (int i = 0; i < captures_; ++i) {
        auto doc = store_->get("/captures/" + capture_id(s, i));
        if (!doc) {
          ++missing;
          ADD_FAILURE() << capture_id(s, i) << " was acknowledged but is lost";
          continue;
        }
        EXPECT_EQ(doc->attrs.value("scout", ""), "scout" + std::to_string(s));
        EXPECT_EQ(store_->get_blob(doc->blobs.at("image")), photo(s, i))
            << capture_id(s, i) << ": stored image differs";
      }
    return missing;
  }

  std::string url_, dir_;
  std::unique_ptr<db::Store> store_;
  int scouts_ = 8, captures_ = 30;
  std::vector<std::string> tokens_;
};

TEST_P(LoadTest, ConcurrentScoutsWithAbortedUploadsStoreEachCaptureOnce) {
  testing::ServeProcess server(ARSCOUT_CLI, url_, dir_ + "/serve.log");
  LoadReport report = run_scouts(server);
  const std::int64_t peak = server.peak_rss_kib(), end = server.rss_kib();

  for (const auto& f : report.total.failures) ADD_FAILURE() << f;
  const std::size_t expected = static_cast<std::size_t>(scouts_ * captures_);
  db::Query all;
  all.pattern = "/captures/*";
  all.limit = expected + 1;  // one more, so that a duplicate would show
  const std::size_t stored = store_->query(all).size();
  EXPECT_EQ(stored, expected);
  // One change per capture: every retry and replay was absorbed.
  EXPECT_EQ(store_->changes(0, "/captures/*", 1000000).size(), expected);
  EXPECT_EQ(store_->stats().blobs, static_cast<std::int64_t>(expected))
      << "interrupted bodies must not leave blobs behind";
  const int lost = check_store_holds_every_capture();

  http::ClientOptions anonymous;
  anonymous.server = server.url();
  http::Client probe(anonymous);
  EXPECT_EQ(probe.get("/healthz").status, 200) << "the server survived";
  EXPECT_LT(peak, kPeakRssBoundKib);

  std::cout << "LOAD " << GetParam() << ": " << scouts_ << " scouts x "
            << captures_ << " captures in " << std::fixed
            << std::setprecision(1) << report.seconds << " s; interrupted "
            << report.total.interrupted << ", retried " << report.total.retries
            << ", replays " << report.total.replays << "; stored " << stored
            << ", duplicates " << (stored > expected ? stored - expected : 0)
            << ", lost " << lost << "; server RSS half-way "
            << report.half_rss_kib / 1024 << " MiB, end " << end / 1024
            << " MiB, peak " << peak / 1024 << " MiB" << std::endl;
  // Retries are expected (a server busy with the interrupted attempts may
  // answer 503); they are listed so that a new kind shows up in the log.
  for (const auto& r : report.total.retry_reasons)
    std::cout << "  retried " << r.substr(0, 200) << "\n";
}

INSTANTIATE_TEST_SUITE_P(Backends, LoadTest,
                         ::testing::Values("sqlite", "postgresql"),
                         [](const auto& info) { return info.param; });

}  // namespace
}  // namespace arscout
