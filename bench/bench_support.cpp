#include "bench_support.h"

#include <libpq-fe.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <stdexcept>
#include <thread>

#include <fcntl.h>
#include <sched.h>
#include <unistd.h>

#include <spdlog/sinks/stdout_sinks.h>
#include <spdlog/spdlog.h>

namespace arscout::bench {

double ms_between(Clock::time_point from, Clock::time_point to) {
  return std::chrono::duration<double, std::milli>(to - from).count();
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  auto rank = static_cast<std::size_t>(q * static_cast<double>(v.size()));
  return v[std::min(rank, v.size() - 1)];
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  std::size_t n = v.size();
  return n % 2 ? v[n / 2] : (v[n / 2 - 1] + v[n / 2]) / 2;
}

std::string fixed(double v, int digits) {
  if (std::isnan(v)) return "n/a";
  char text[64];
  std::snprintf(text, sizeof text, "%.*f", digits, v);
  return text;
}

bool starts_with(const std::string& s, const std::string& prefix) {
  return s.compare(0, prefix.size(), prefix) == 0;
}

WalkWindows walk_windows(int views) {
  WalkWindows w;
  w.last_end = views;
  w.shrunk = views < 220;
  const int last_count = w.shrunk ? std::min(100, views / 2) : 100;
  if (w.shrunk) w.first_end = std::min(120, views / 2);
  w.last_begin = views - last_count + 1;
  return w;
}

// --- scratch databases -------------------------------------------------------

namespace {

class GivenDb : public ScratchDb {
 public:
  explicit GivenDb(std::string url) : url_(std::move(url)) {}
  std::string url() const override { return url_; }

 private:
  std::string url_;
};

class SqliteScratch : public ScratchDb {
 public:
  SqliteScratch(const std::string& parent, const std::string& tool) {
    std::string templ = parent + "/" + tool + ".XXXXXX";
    if (mkdtemp(templ.data()) == nullptr)
      throw std::runtime_error("cannot create a temp dir under " + parent);
    dir_ = templ;
  }
  ~SqliteScratch() override {
    std::error_code ignored;
    std::filesystem::remove_all(dir_, ignored);
  }
  std::string url() const override { return "sqlite:" + dir_ + "/bench.db"; }

 private:
  std::string dir_;
};

// Runs one statement on the server through libpq (the store has no API for
// creating databases).
void pg_exec(const std::string& url, const std::string& sql) {
  std::unique_ptr<PGconn, decltype(&PQfinish)> conn(PQconnectdb(url.c_str()),
                                                    &PQfinish);
  if (PQstatus(conn.get()) != CONNECTION_OK)
    throw std::runtime_error("cannot connect to PostgreSQL: " +
                             std::string(PQerrorMessage(conn.get())));
  std::unique_ptr<PGresult, decltype(&PQclear)> result(
      PQexec(conn.get(), sql.c_str()), &PQclear);
  if (PQresultStatus(result.get()) != PGRES_COMMAND_OK)
    throw std::runtime_error(sql + ": " +
                             std::string(PQerrorMessage(conn.get())));
}

// The URL with its database name replaced by name.
std::string with_database(const std::string& url, const std::string& name) {
  std::size_t authority = url.find("://") + 3;
  std::size_t query = url.find('?', authority);
  std::size_t end = query == std::string::npos ? url.size() : query;
  std::size_t slash = url.find('/', authority);
  if (slash == std::string::npos || slash > end)
    return url.substr(0, end) + "/" + name + url.substr(end);
  return url.substr(0, slash + 1) + name + url.substr(end);
}

class PgScratch : public ScratchDb {
 public:
  PgScratch(std::string admin_url, std::string tool, int run)
      : admin_url_(std::move(admin_url)),
        tool_(std::move(tool)),
        name_("arscout_bench_" + std::to_string(getpid()) + "_" +
              std::to_string(run)) {
    pg_exec(admin_url_, "CREATE DATABASE " + name_);
  }
  ~PgScratch() override {
    try {
      // FORCE: a connection the store left behind must not keep it alive.
      pg_exec(admin_url_, "DROP DATABASE IF EXISTS " + name_ + " WITH (FORCE)");
    } catch (const std::exception& e) {
      std::cerr << tool_ << ": warning: " << e.what() << "\n";
    }
  }
  std::string url() const override { return with_database(admin_url_, name_); }

 private:
  std::string admin_url_;
  std::string tool_;
  std::string name_;
};

bool is_postgres_url(const std::string& url) {
  return starts_with(url, "postgresql://") || starts_with(url, "postgres://");
}

}  // namespace

std::unique_ptr<ScratchDb> make_scratch(const ScratchSpec& spec, int run) {
  if (spec.reuse) return std::make_unique<GivenDb>(spec.url);
  if (starts_with(spec.url, "sqlite:"))
    return std::make_unique<SqliteScratch>(spec.tmp_dir, spec.tool);
  if (is_postgres_url(spec.url))
    return std::make_unique<PgScratch>(spec.url, spec.tool, run);
  throw std::runtime_error("--db " + spec.url +
                           ": must start with sqlite: or postgresql://");
}

std::string backend_name(const std::string& url) {
  return starts_with(url, "sqlite:") ? "sqlite" : "postgresql";
}

// --- results -----------------------------------------------------------------

void Results::add(const std::string& name, const std::string& unit,
                  double value) {
  for (Metric& m : metrics) {
    if (m.name == name) {
      m.values.push_back(value);
      return;
    }
  }
  metrics.push_back({name, unit, {value}});
}

void print_metrics(const Results& results) {
  std::printf("%-40s %12s %12s %12s  %s\n", "metric", "median", "min", "max",
              "unit");
  for (const auto& m : results.metrics) {
    auto [lo, hi] = std::minmax_element(m.values.begin(), m.values.end());
    std::printf("%-40s %12.2f %12.2f %12.2f  %s\n", m.name.c_str(),
                median(m.values), *lo, *hi, m.unit.c_str());
  }
  std::fflush(stdout);
}

void measure_fdatasync(const std::string& dir, Results& out) {
  std::string path = dir + "/bench-fsync." + std::to_string(getpid());
  int fd = open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
  if (fd < 0) throw std::runtime_error("cannot create " + path);
  std::string page(8192, 'x');
  std::vector<double> ms;
  for (int i = 0; i < 200; ++i) {
    auto t0 = Clock::now();
    bool ok = pwrite(fd, page.data(), page.size(), 0) ==
                  static_cast<ssize_t>(page.size()) &&
              fdatasync(fd) == 0;
    ms.push_back(ms_between(t0, Clock::now()));
    if (!ok) break;
  }
  close(fd);
  unlink(path.c_str());
  out.add("disk: 8 KiB write+fdatasync p50", "ms", percentile(ms, 0.50));
  out.add("disk: 8 KiB write+fdatasync p99", "ms", percentile(ms, 0.99));
}

void configure_logging(const std::string& logger_name) {
  auto logger = spdlog::stderr_logger_mt(logger_name);
  spdlog::set_default_logger(logger);
  spdlog::set_level(spdlog::level::warn);
}

// --- machine -----------------------------------------------------------------

namespace {

// The value after the first "key<spaces>: " line of a /proc file, or "?".
std::string proc_field(const std::string& file, const std::string& key) {
  std::ifstream in(file);
  std::string line;
  while (std::getline(in, line)) {
    if (!starts_with(line, key)) continue;
    std::size_t colon = line.find(':');
    if (colon == std::string::npos) continue;
    std::size_t value = line.find_first_not_of(" \t", colon + 1);
    return value == std::string::npos ? "" : line.substr(value);
  }
  return "?";
}

std::string utc_now() {
  std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%d %H:%M:%S UTC", &tm);
  return buf;
}

// Like nproc: the CPUs this process may run on.
int cpu_count() {
  cpu_set_t set;
  if (sched_getaffinity(0, sizeof set, &set) == 0) return CPU_COUNT(&set);
  return static_cast<int>(std::thread::hardware_concurrency());
}

}  // namespace

std::string load_average() {
  std::ifstream in("/proc/loadavg");
  std::string one, five, fifteen;
  if (!(in >> one >> five >> fifteen)) return "?";
  return one + " " + five + " " + fifteen;
}

std::string machine_summary() {
  std::string memory = proc_field("/proc/meminfo", "MemTotal");
  return "date:    " + utc_now() + "\n" +
         "machine: " + std::to_string(cpu_count()) + " CPUs, " +
         proc_field("/proc/cpuinfo", "model name") + ", " + memory +
         " memory\n" + "load:    " + load_average() + " (1/5/15 min)\n";
}

}  // namespace arscout::bench
