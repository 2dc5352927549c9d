// store_bench: throughput and change-feed latency of the document store on one
// backend, each figure the median of several runs on a fresh database.
//
//   store_bench --db sqlite:              fresh SQLite file per run (in a new
//                                         temp dir under --tmp-dir)
//   store_bench --db postgresql://...     fresh database per run, created on
//                                         that server and dropped afterwards
//
// bench/run-store-bench.sh runs both backends; bench/RESULTS.md has figures.
#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <latch>
#include <memory>
#include <mutex>
#include <optional>
#include <random>
#include <stdexcept>
#include <streambuf>
#include <string>
#include <thread>
#include <unordered_map>
#include <vector>

#include <unistd.h>

#include <CLI/CLI.hpp>

#include "arscout/db/store.h"
#include "bench_support.h"

namespace {

namespace db = arscout::db;
using arscout::bench::Clock;
using arscout::bench::ms_between;
using arscout::bench::percentile;
using arscout::bench::Results;
using arscout::bench::seconds_since;

struct Config {
  std::string url;
  int runs = 5;
  int docs = 2000;        // single-writer puts; also the docs read back
  int reads = 20000;      // gets, cycling over those docs
  int writers = 8;        // threads of the parallel-write phase
  int writer_docs = 250;  // puts per thread
  int blob_mib = 32;
  int wakeups = 500;
  int wake_gap_ms = 2;    // pause between wake-up writes
  int pool = 0;           // OpenOptions::pool_size; 0 keeps the default
  bool reuse_db = false;  // use --db as given instead of fresh databases
  std::string tmp_dir;
};

// --- streams -----------------------------------------------------------------

// Reads a string as a stream without copying it.
class ViewBuffer : public std::streambuf {
 public:
  explicit ViewBuffer(std::string& bytes) {
    setg(bytes.data(), bytes.data(), bytes.data() + bytes.size());
  }
};

// Discards what is written and counts it: read_blob's cost without a copy.
class CountingBuffer : public std::streambuf {
 public:
  std::int64_t count() const { return count_; }

 protected:
  std::streamsize xsputn(const char*, std::streamsize n) override {
    count_ += n;
    return n;
  }
  int_type overflow(int_type ch) override {
    if (!traits_type::eq_int_type(ch, traits_type::eof())) ++count_;
    return traits_type::not_eof(ch);
  }

 private:
  std::int64_t count_ = 0;
};

std::string random_bytes(std::size_t size, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::string out(size, '\0');
  for (std::size_t i = 0; i + 8 <= size; i += 8) {
    std::uint64_t word = rng();
    std::memcpy(out.data() + i, &word, 8);
  }
  return out;
}

// --- measurements ------------------------------------------------------------

db::Json small_doc(int i) {
  return {{"i", i},
          {"name", "capture-" + std::to_string(i)},
          {"status", "new"},
          {"gps", {{"lat", 48.137 + i * 1e-6}, {"lon", 11.575}}}};
}

std::vector<std::string> doc_paths(const std::string& prefix, int n) {
  std::vector<std::string> paths;
  paths.reserve(n);
  for (int i = 0; i < n; ++i)
    paths.push_back(prefix + "/d" + std::to_string(i));
  return paths;
}

void measure_single_writes(db::Store& store,
                           const std::vector<std::string>& paths,
                           Results& out) {
  std::vector<double> latency_ms;
  latency_ms.reserve(paths.size());
  auto start = Clock::now();
  for (std::size_t i = 0; i < paths.size(); ++i) {
    auto t0 = Clock::now();
    store.put(paths[i], "bench", small_doc(static_cast<int>(i)));
    latency_ms.push_back(ms_between(t0, Clock::now()));
  }
  out.add("single-document writes", "writes/s",
          static_cast<double>(paths.size()) / seconds_since(start));
  out.add("  write latency p50", "ms", percentile(latency_ms, 0.50));
  out.add("  write latency p99", "ms", percentile(latency_ms, 0.99));
}

void measure_reads(db::Store& store, const std::vector<std::string>& paths,
                   int reads, Results& out) {
  auto start = Clock::now();
  for (int i = 0; i < reads; ++i) {
    if (!store.get(paths[static_cast<std::size_t>(i) % paths.size()]))
      throw std::runtime_error("a written document is missing");
  }
  out.add("single-document reads", "reads/s", reads / seconds_since(start));
}

void measure_parallel_writes(db::Store& store, const Config& cfg,
                             const std::string& prefix, Results& out) {
  std::latch ready(cfg.writers + 1);
  std::vector<std::exception_ptr> errors(cfg.writers);
  std::vector<std::thread> threads;
  for (int t = 0; t < cfg.writers; ++t) {
    threads.emplace_back([&, t] {
      auto paths =
          doc_paths(prefix + "/t" + std::to_string(t), cfg.writer_docs);
      ready.arrive_and_wait();  // all threads start writing together
      try {
        for (int i = 0; i < cfg.writer_docs; ++i)
          store.put(paths[i], "bench", small_doc(i));
      } catch (...) {
        errors[t] = std::current_exception();
      }
    });
  }
  ready.arrive_and_wait();
  auto start = Clock::now();
  for (std::thread& t : threads) t.join();
  double elapsed = seconds_since(start);
  for (const auto& e : errors)
    if (e) std::rethrow_exception(e);
  out.add(std::to_string(cfg.writers) + "-writer writes (total)", "writes/s",
          cfg.writers * cfg.writer_docs / elapsed);
}

void measure_blobs(db::Store& store, const Config& cfg, int run, Results& out) {
  const std::size_t size = static_cast<std::size_t>(cfg.blob_mib) << 20;
  // Different bytes every run: the store keeps equal blobs once.
  std::string bytes = random_bytes(size, 0x5eed0000u + run);
  ViewBuffer view(bytes);
  std::istream in(&view);
  auto start = Clock::now();
  std::string sha = store.put_blob(in);
  double write_s = seconds_since(start);

  CountingBuffer counter;
  std::ostream sink(&counter);
  start = Clock::now();
  store.read_blob(sha, sink);
  double read_s = seconds_since(start);
  if (counter.count() != static_cast<std::int64_t>(size))
    throw std::runtime_error("read_blob returned a short blob");
  std::string size_tag = " (" + std::to_string(cfg.blob_mib) + " MiB)";
  out.add("blob write" + size_tag, "MiB/s", cfg.blob_mib / write_s);
  out.add("blob read" + size_tag, "MiB/s", cfg.blob_mib / read_s);
}

// Times at which changes reached a subscriber's callback, by seq.
class Arrivals {
 public:
  void record(std::int64_t seq) {
    auto now = Clock::now();
    {
      std::lock_guard lock(mu_);
      at_.emplace(seq, now);  // delivery is at-least-once: keep the first
    }
    cv_.notify_all();
  }
  bool wait_for(std::int64_t seq, std::chrono::seconds timeout) {
    std::unique_lock lock(mu_);
    return cv_.wait_for(lock, timeout, [&] { return at_.count(seq) > 0; });
  }
  std::optional<Clock::time_point> at(std::int64_t seq) {
    std::lock_guard lock(mu_);
    auto it = at_.find(seq);
    if (it == at_.end()) return std::nullopt;
    return it->second;
  }

 private:
  std::mutex mu_;
  std::condition_variable cv_;
  std::unordered_map<std::int64_t, Clock::time_point> at_;
};

struct SentWrite {
  std::int64_t seq;
  Clock::time_point started;   // just before put()
  Clock::time_point returned;  // just after put() returned
};

// Writes cfg.wakeups documents, spaced so that each is a wake-up of its own,
// while `listener` has a subscriber recording when each change arrives.
// Latency is measured from put()'s return (the commit is then known to be
// durable) to the callback; a callback that ran before put() returned counts
// as 0. put start -> callback is reported too, commit time included.
void measure_wakeups(db::Store& writer, db::Store& listener, const Config& cfg,
                     const std::string& prefix, const std::string& label,
                     Results& out) {
  Arrivals arrivals;
  auto sub =
      listener.subscribe(prefix + "/**", listener.last_seq(),
                         [&](const db::Change& c) { arrivals.record(c.seq); });
  // Warm-up: the subscriber thread (and a PostgreSQL LISTEN connection) must
  // be running before the first timed write.
  auto warm = writer.put(prefix + "/warm", "bench", db::Json::object());
  if (!arrivals.wait_for(warm.seq, std::chrono::seconds(10)))
    throw std::runtime_error("subscriber never received the warm-up write");
  std::this_thread::sleep_for(std::chrono::milliseconds(300));

  std::vector<SentWrite> sent;
  sent.reserve(cfg.wakeups);
  for (int i = 0; i < cfg.wakeups; ++i) {
    auto started = Clock::now();
    db::Json attrs = {
        {"i", i},
        {"t_ns", std::chrono::duration_cast<std::chrono::nanoseconds>(
                     started.time_since_epoch())
                     .count()}};
    auto r = writer.put(prefix + "/d" + std::to_string(i), "bench", attrs);
    sent.push_back({r.seq, started, Clock::now()});
    std::this_thread::sleep_for(std::chrono::milliseconds(cfg.wake_gap_ms));
  }
  if (!arrivals.wait_for(sent.back().seq, std::chrono::seconds(10)))
    throw std::runtime_error("subscriber missed wake-up writes");
  sub->stop();

  std::vector<double> wake_ms, total_ms;
  for (const SentWrite& s : sent) {
    auto at = arrivals.at(s.seq);
    if (!at) throw std::runtime_error("a change was never delivered");
    wake_ms.push_back(std::max(0.0, ms_between(s.returned, *at)));
    total_ms.push_back(ms_between(s.started, *at));
  }
  out.add("wake-up p50, " + label, "ms", percentile(wake_ms, 0.50));
  out.add("wake-up p99, " + label, "ms", percentile(wake_ms, 0.99));
  out.add("  put start -> callback p99, " + label, "ms",
          percentile(total_ms, 0.99));
}

db::OpenOptions open_options(const Config& cfg) {
  db::OpenOptions options;
  if (cfg.pool > 0) options.pool_size = cfg.pool;
  return options;
}

void run_once(const Config& cfg, int run, Results& out) {
  // The scratch database outlives the stores below.
  auto scratch = arscout::bench::make_scratch(
      {cfg.url, cfg.tmp_dir, "store_bench", cfg.reuse_db}, run);
  auto store = db::Store::open(scratch->url(), open_options(cfg));
  // Unique per run, so that --reuse-db runs never write the same paths.
  std::string prefix =
      "/bench/p" + std::to_string(getpid()) + "-r" + std::to_string(run);

  arscout::bench::measure_fdatasync(cfg.tmp_dir, out);
  auto paths = doc_paths(prefix + "/single", cfg.docs);
  measure_single_writes(*store, paths, out);
  measure_reads(*store, paths, cfg.reads, out);
  measure_parallel_writes(*store, cfg, prefix + "/multi", out);
  measure_blobs(*store, cfg, run, out);
  measure_wakeups(*store, *store, cfg, prefix + "/wake1", "same Store", out);
  // A second Store on the same database wakes as another process would:
  // LISTEN/NOTIFY on PostgreSQL, only polling on SQLite.
  auto other = db::Store::open(scratch->url(), open_options(cfg));
  measure_wakeups(*store, *other, cfg, prefix + "/wake2", "other Store", out);
}

// --- output ------------------------------------------------------------------

void print_table(const std::string& backend, const Config& cfg,
                 const Results& results) {
  std::printf(
      "store_bench: backend=%s runs=%d docs=%d reads=%d writers=%d"
      "x%d blob=%d MiB wakeups=%d gap=%d ms pool=%s\n",
      backend.c_str(), cfg.runs, cfg.docs, cfg.reads, cfg.writers,
      cfg.writer_docs, cfg.blob_mib, cfg.wakeups, cfg.wake_gap_ms,
      cfg.pool > 0 ? std::to_string(cfg.pool).c_str() : "default");
  arscout::bench::print_metrics(results);
}

void add_options(CLI::App& app, Config& cfg) {
  app.add_option("--db", cfg.url,
                 "sqlite: (fresh file per run under --tmp-dir) or "
                 "postgresql://... (fresh database per run on that server)")
      ->required();
  app.add_option("--runs", cfg.runs, "runs; figures are their median")
      ->check(CLI::PositiveNumber);
  app.add_option("--docs", cfg.docs, "single-writer puts per run")
      ->check(CLI::PositiveNumber);
  app.add_option("--reads", cfg.reads, "gets per run")
      ->check(CLI::PositiveNumber);
  app.add_option("--writers", cfg.writers, "threads of the parallel phase")
      ->check(CLI::PositiveNumber);
  app.add_option("--writer-docs", cfg.writer_docs, "puts per writer thread")
      ->check(CLI::PositiveNumber);
  app.add_option("--blob-mib", cfg.blob_mib, "blob size in MiB")
      ->check(CLI::PositiveNumber);
  app.add_option("--wakeups", cfg.wakeups, "writes timed to the subscriber")
      ->check(CLI::PositiveNumber);
  app.add_option("--wake-gap-ms", cfg.wake_gap_ms, "pause between them")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--pool", cfg.pool, "OpenOptions::pool_size (0: default)")
      ->check(CLI::NonNegativeNumber);
  app.add_flag("--reuse-db", cfg.reuse_db,
               "write into --db as given (unique paths per run) instead of a "
               "fresh database per run");
  app.add_option("--tmp-dir", cfg.tmp_dir,
                 "where fresh SQLite files go and fdatasync is timed")
      ->check(CLI::ExistingDirectory);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"store_bench: document store throughput and wake-up latency"};
  Config cfg;
  const char* tmp = std::getenv("TMPDIR");
  cfg.tmp_dir = tmp && *tmp ? tmp : "/tmp";
  add_options(app, cfg);
  CLI11_PARSE(app, argc, argv);
  arscout::bench::configure_logging("store_bench");
  try {
    Results results;
    for (int run = 0; run < cfg.runs; ++run) {
      std::fprintf(stderr, "store_bench: run %d/%d\n", run + 1, cfg.runs);
      run_once(cfg, run, results);
    }
    print_table(arscout::bench::backend_name(cfg.url), cfg, results);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "store_bench: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
