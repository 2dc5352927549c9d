// Helpers shared by the benchmarks (store_bench, ingest_bench): timing and
// percentiles, a fresh scratch database per run, per-run figures printed as
// a median/min/max table, a disk-latency probe and a machine description.
#pragma once

#include <chrono>

#include <memory>
#include <string>
#include <vector>
#include "arscout/util/clock.h"

namespace arscout::bench {

using Clock = std::chrono::steady_clock;

using util::seconds_since;
double ms_between(Clock::time_point from, Clock::time_point to);
// Nearest-rank percentile of unsorted samples (q in [0, 1]); 0 when empty.
double percentile(std::vector<double> v, double q);
double median(std::vector<double> v);
// v with `digits` decimals, "n/a" for NaN (a figure a run could not get).
std::string fixed(double v, int digits);
bool starts_with(const std::string& s, const std::string& prefix);

// The early and the late window of a walk of `views` photos (1-based photo
// numbers, inclusive) over which the scale and service benches compare the
// per-photo cost: photos 21-120 and the last 100, or below 220 photos
// 21..min(120, N/2) and the last min(100, N/2) (`shrunk`).
struct WalkWindows {
  int first_begin = 21, first_end = 120;
  int last_begin = 0, last_end = 0;
  bool shrunk = false;
};
WalkWindows walk_windows(int views);

// --- scratch databases -------------------------------------------------------

// The database one run works on. Fresh ones are deleted on destruction, so
// every run starts from an empty store and none inherits another's bloat.
class ScratchDb {
 public:
  virtual ~ScratchDb() = default;
  virtual std::string url() const = 0;
};

struct ScratchSpec {
  std::string url;      // sqlite: (any path is ignored) or postgresql://...
  std::string tmp_dir;  // where fresh SQLite files go
  std::string tool;     // names temp dirs and warnings, e.g. "store_bench"
  bool reuse = false;   // use url as given instead of a fresh database
};

// A fresh SQLite file in a new temp dir under spec.tmp_dir, or a fresh
// database created on the PostgreSQL server of spec.url (through libpq) and
// dropped afterwards. Throws std::runtime_error for another URL scheme.
std::unique_ptr<ScratchDb> make_scratch(const ScratchSpec& spec, int run);
// "sqlite" or "postgresql", by the URL's scheme.
std::string backend_name(const std::string& url);

// --- results -----------------------------------------------------------------

struct Results {
  struct Metric {
    std::string name;
    std::string unit;
    std::vector<double> values;  // one per run
  };
  std::vector<Metric> metrics;  // in the order first added

  void add(const std::string& name, const std::string& unit, double value);
};

// The column header and one row per metric (median, min, max of its runs)
// on stdout.
void print_metrics(const Results& results);

// Median and p99 time of an 8 KiB write + fdatasync in dir, the floor under
// every durable commit. Cloud disks vary it several-fold from minute to
// minute, so each run records it beside the figures it explains.
void measure_fdatasync(const std::string& dir, Results& out);

// The stores log warnings through spdlog; keep them on stderr, off the table.
void configure_logging(const std::string& logger_name);

// "date: ...", "machine: ..." and "load: ..." lines (UTC date, CPUs, CPU
// model, memory, load average).
std::string machine_summary();
// "1-min 5-min 15-min" from /proc/loadavg.
std::string load_average();

}  // namespace arscout::bench
