// ingest_bench: the HTTP ingest path end to end on one backend, each figure
// the median of several runs on a fresh store: an in-process Server on
// 127.0.0.1 (any free port, default ServerOptions but no upload limits) over
// that store, driven by N client threads with one http::Client and one scout
// token each.
//
//   uploads: POST /v1/captures of real 1-3 MB JPEGs (raw body, metadata with
//            a unique capture_id and a GPS fix in X-Capture-Metadata); every
//            answer must be 201, and afterwards the store must hold exactly
//            one /captures/* document and one blob per upload.
//   gets:    GET /v1/docs/{path} of 1000 small documents; every answer 200.
//
// Both run once with 1 client (the unloaded latency) and once with --clients.
//
//   ingest_bench --db sqlite:            fresh SQLite file per run
//   ingest_bench --db postgresql://...   fresh database per run on that server
//
// bench/run-ingest-bench.sh runs both backends; bench/RESULTS.md has figures.
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <latch>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>

#include "arscout/db/store.h"
#include "arscout/http/client.h"
#include "arscout/ingest/auth.h"
#include "arscout/ingest/server.h"
#include "bench_support.h"

namespace {

namespace db = arscout::db;
namespace http = arscout::http;
namespace ingest = arscout::ingest;
using arscout::bench::Clock;
using arscout::bench::ms_between;
using arscout::bench::percentile;
using arscout::bench::Results;
using arscout::bench::seconds_since;
using arscout::bench::starts_with;

struct Config {
  std::string url;
  int runs = 3;
  int clients = 8;
  int uploads_per_client = 24;
  int gets_per_client = 1000;
  int docs = 1000;  // small documents the GET phase reads
  std::string data_dir;
  std::string tmp_dir;
};

// Image folders under --data-dir: ~3 MB (3072x2048) and ~1.3 MB (3264x2448).
const char* const kImageDirs[] = {"strecha/fountain-P11/images",
                                  "opensfm/berlin/images"};

// --- images ------------------------------------------------------------------

struct Image {
  std::string name;
  std::string bytes;
};

std::string read_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + path.string());
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// The *.jpg files of dir, by name.
std::vector<Image> load_images(const std::filesystem::path& dir) {
  std::vector<std::filesystem::path> files;
  for (const auto& entry : std::filesystem::directory_iterator(dir))
    if (entry.path().extension() == ".jpg") files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  std::vector<Image> images;
  for (const auto& f : files)
    images.push_back({f.filename().string(), read_file(f)});
  return images;
}

std::vector<Image> load_corpus(const std::string& data_dir) {
  std::vector<Image> all;
  for (const char* sub : kImageDirs) {
    std::filesystem::path dir = std::filesystem::path(data_dir) / sub;
    if (!std::filesystem::is_directory(dir))
      throw std::runtime_error(dir.string() + " not found (see --data-dir)");
    auto images = load_images(dir);
    std::move(images.begin(), images.end(), std::back_inserter(all));
  }
  if (all.empty()) throw std::runtime_error("no JPEGs under " + data_dir);
  return all;
}

// The JPEG with a comment segment (FF FE) holding tag inserted right after
// its start-of-image marker: still a valid JPEG, but with bytes of its own,
// as every real photo has (the store keeps equal blobs once).
void tagged_jpeg(const std::string& jpeg, const std::string& tag,
                 std::string* out) {
  const std::size_t length = tag.size() + 2;  // the length field counts itself
  out->assign(jpeg, 0, 2);
  out->append({'\xFF', '\xFE', static_cast<char>(length >> 8),
               static_cast<char>(length & 0xFF)});
  out->append(tag);
  out->append(jpeg, 2);
}

// --- a server on a fresh store -----------------------------------------------

// Members are destroyed bottom-up: the server stops before the store closes,
// and the store closes before its scratch database is deleted.
struct Fixture {
  std::unique_ptr<arscout::bench::ScratchDb> scratch;
  std::unique_ptr<db::Store> store;
  std::unique_ptr<ingest::Server> server;
  std::string base_url;
  std::vector<std::string> tokens;  // one scout token per client
};

std::unique_ptr<Fixture> start_fixture(const Config& cfg, int run) {
  auto fx = std::make_unique<Fixture>();
  fx->scratch = arscout::bench::make_scratch(
      {cfg.url, cfg.tmp_dir, "ingest_bench", false}, run);
  fx->store = db::Store::open(fx->scratch->url());
  ingest::ServerOptions options;
  options.port = 0;  // any free port
  // The throughput of the path, not of the per-token limits (docs/api.md,
  // "Limits"), which would refuse a client sending as fast as it can.
  options.uploads_per_hour = 0;
  options.new_places_per_hour = 0;
  fx->server = std::make_unique<ingest::Server>(*fx->store, options);
  fx->server->start();
  fx->base_url = "http://127.0.0.1:" + std::to_string(fx->server->port());
  for (int c = 0; c < cfg.clients; ++c)
    fx->tokens.push_back(ingest::create_token(
        *fx->store, ingest::Role::kScout, "bench-scout-" + std::to_string(c)));
  return fx;
}

// --- clients -----------------------------------------------------------------

// Requests that did not get the expected answer, by kind ("HTTP 500",
// "network"), with the first message of each kind.
class Failures {
 public:
  void record(const std::string& kind, const std::string& message) {
    std::lock_guard lock(mu_);
    ++by_kind_.try_emplace(kind, 0, message).first->second.first;
  }
  // Throws, naming every kind, when any request failed.
  void throw_if_any(const std::string& phase, int requests) const {
    if (by_kind_.empty()) return;
    std::ostringstream out;
    int failed = 0;
    for (const auto& [kind, entry] : by_kind_) failed += entry.first;
    out << phase << ": " << failed << " of " << requests << " requests failed";
    for (const auto& [kind, entry] : by_kind_)
      out << "\n  " << entry.first << " x " << kind
          << ", first: " << entry.second;
    throw std::runtime_error(out.str());
  }

 private:
  std::mutex mu_;
  std::map<std::string, std::pair<int, std::string>> by_kind_;
};

std::string excerpt(const std::string& body) {
  return body.size() <= 300 ? body : body.substr(0, 300) + "...";
}

// What one client thread does once all clients are connected: its requests,
// each timed into latency_ms.
using ClientWork = std::function<void(int client, http::Client& http,
                                      std::vector<double>& latency_ms)>;

struct PhaseTiming {
  double seconds = 0;              // all clients released -> all done
  std::vector<double> latency_ms;  // every request of every client
  double handler_ms = 0;  // mean time in the server's handler, from /metrics
};

// Connects `clients` clients (one keep-alive connection each, opened by a
// GET /healthz before the clock starts), releases them together and waits.
PhaseTiming run_clients(const Fixture& fx, int clients, const ClientWork& work,
                        Failures& failures) {
  std::latch connected(clients), go(1);
  std::vector<std::vector<double>> latency(clients);
  std::vector<std::thread> threads;
  for (int c = 0; c < clients; ++c) {
    threads.emplace_back([&, c] {
      http::ClientOptions options;
      options.server = fx.base_url;
      options.token = fx.tokens[c];
      http::Client http(options);
      bool ok = false;
      try {
        http::HttpResult health = http.get("/healthz");
        ok = health.status == 200;
        if (!ok) failures.record("connect", "GET /healthz: " + health.body);
      } catch (const std::exception& e) {
        failures.record("connect", e.what());
      }
      connected.count_down();
      go.wait();
      try {
        if (ok) work(c, http, latency[c]);
      } catch (const std::exception& e) {  // e.g. an answer that is not JSON
        failures.record("exception", e.what());
      }
    });
  }
  connected.wait();
  auto start = Clock::now();
  go.count_down();
  for (std::thread& t : threads) t.join();
  PhaseTiming timing{seconds_since(start), {}};
  for (const auto& l : latency)
    timing.latency_ms.insert(timing.latency_ms.end(), l.begin(), l.end());
  return timing;
}

// Sends one request and times it; a NetworkError is recorded as a failure.
std::optional<http::HttpResult> timed_request(
    http::Client& http, const std::string& method, const std::string& target,
    const std::string& body,
    const std::vector<std::pair<std::string, std::string>>& headers,
    std::vector<double>& latency_ms, Failures& failures) {
  try {
    auto t0 = Clock::now();
    http::HttpResult result = http.request(method, target, body, headers);
    latency_ms.push_back(ms_between(t0, Clock::now()));
    return result;
  } catch (const http::NetworkError& e) {
    failures.record("network", e.what());
    return std::nullopt;
  }
}

// A route's request count and total handler seconds, from GET /metrics.
struct RouteTotals {
  double seconds = 0;
  double count = 0;
};

RouteTotals route_totals(const Fixture& fx, const std::string& route) {
  http::ClientOptions options;
  options.server = fx.base_url;
  http::Client http(options);
  http::HttpResult r = http.get("/metrics");
  if (r.status != 200)
    throw std::runtime_error("GET /metrics: status " +
                             std::to_string(r.status));
  const std::string metric = "arscout_http_request_duration_seconds";
  const std::string labels = "{route=\"" + route + "\"} ";
  RouteTotals totals;
  std::istringstream in(r.body);
  std::string line;
  while (std::getline(in, line)) {
    if (starts_with(line, metric + "_sum" + labels))
      totals.seconds = std::stod(line.substr(line.rfind(' ') + 1));
    if (starts_with(line, metric + "_count" + labels))
      totals.count = std::stod(line.substr(line.rfind(' ') + 1));
  }
  return totals;
}

// run_clients, plus the mean handler time of `route` over the phase.
PhaseTiming run_phase(const Fixture& fx, const std::string& route, int clients,
                      const ClientWork& work, Failures& failures) {
  RouteTotals before = route_totals(fx, route);
  PhaseTiming timing = run_clients(fx, clients, work, failures);
  RouteTotals after = route_totals(fx, route);
  if (after.count > before.count)
    timing.handler_ms =
        1000 * (after.seconds - before.seconds) / (after.count - before.count);
  return timing;
}

std::string label(int clients) {
  return std::to_string(clients) + (clients == 1 ? " client" : " clients");
}

void add_latency(const std::string& what, int clients, const PhaseTiming& t,
                 Results& out) {
  out.add("  " + what + " latency p50, " + label(clients), "ms",
          percentile(t.latency_ms, 0.50));
  out.add("  " + what + " latency p99, " + label(clients), "ms",
          percentile(t.latency_ms, 0.99));
  out.add("  " + what + " server handler mean, " + label(clients), "ms",
          t.handler_ms);
}

// --- uploads -----------------------------------------------------------------

db::Json capture_metadata(const std::string& id, const Image& image,
                          int serial) {
  return {{"capture_id", id},
          {"filename", image.name},
          {"taken", "2026-11-21T13:05:00Z"},
          {"gps",
           {{"lat", 47.0707 + 1e-6 * serial},
            {"lon", 15.4395},
            {"alt", 353.0},
            {"h_acc", 3.5},
            {"v_acc", 7.0},
            {"satellites", 8},
            {"time", "2026-11-21T13:05:00Z"}}}};
}

// Empty when the answer is the 201 of a newly stored capture `id`.
std::string upload_problem(const http::HttpResult& r, const std::string& id) {
  if (r.status != 201) return excerpt(r.body);
  if (r.headers.count("idempotent-replay")) return "an idempotent replay";
  db::Json doc = r.json();
  // Stored in the scout's own space: "/captures/{scout}.{id}".
  const std::string path = doc.value("path", "");
  const std::string tail = "." + id;
  if (path.rfind("/captures/", 0) != 0 || path.size() < tail.size() ||
      path.compare(path.size() - tail.size(), tail.size(), tail) != 0)
    return "201 for another path: " + excerpt(r.body);
  if (doc["attrs"].value("status", "") != "stored")
    return "status is not 'stored': " + excerpt(r.body);
  return "";
}

struct UploadPlan {
  const std::vector<Image>& images;
  std::string id_prefix;  // unique per phase and run
  int per_client = 0;
};

// One client's uploads, cycling through the images from an offset of its own
// so that the clients send different images at the same time.
void upload_all(const UploadPlan& plan, int client, http::Client& http,
                std::vector<double>& latency_ms, Failures& failures) {
  std::string body;
  for (int i = 0; i < plan.per_client; ++i) {
    int serial = client * plan.per_client + i;
    const Image& image = plan.images[serial % plan.images.size()];
    std::string id = plan.id_prefix + "-c" + std::to_string(client) + "-u" +
                     std::to_string(i);
    tagged_jpeg(image.bytes, id, &body);
    auto result = timed_request(
        http, "POST", "/v1/captures", body,
        {{"Content-Type", "image/jpeg"},
         {"X-Capture-Metadata", capture_metadata(id, image, serial).dump()}},
        latency_ms, failures);
    if (!result) continue;
    std::string problem = upload_problem(*result, id);
    if (!problem.empty())
      failures.record("HTTP " + std::to_string(result->status), problem);
  }
}

std::int64_t planned_bytes(const UploadPlan& plan, int clients) {
  std::int64_t bytes = 0;
  for (int serial = 0; serial < clients * plan.per_client; ++serial)
    bytes += static_cast<std::int64_t>(
        plan.images[serial % plan.images.size()].bytes.size());
  return bytes;
}

void measure_uploads(const Fixture& fx, const UploadPlan& plan, int clients,
                     Results& out) {
  Failures failures;
  PhaseTiming t = run_phase(
      fx, "POST /v1/captures", clients,
      [&](int c, http::Client& http, std::vector<double>& latency_ms) {
        upload_all(plan, c, http, latency_ms, failures);
      },
      failures);
  failures.throw_if_any("uploads, " + label(clients),
                        clients * plan.per_client);
  double mib = static_cast<double>(planned_bytes(plan, clients)) / (1 << 20);
  out.add("uploads, " + label(clients), "uploads/s",
          clients * plan.per_client / t.seconds);
  out.add("  upload volume, " + label(clients), "MiB/s", mib / t.seconds);
  add_latency("upload", clients, t, out);
}

// The store must hold exactly `expected` captures, all stored, each with a
// blob of its own.
void verify_captures(db::Store& store, std::size_t expected) {
  auto captures = store.list_children("/captures");
  if (captures.size() != expected)
    throw std::runtime_error("the store holds " +
                             std::to_string(captures.size()) +
                             " /captures/* documents after " +
                             std::to_string(expected) + " successful uploads");
  for (const db::Document& doc : captures)
    if (doc.attrs.value("status", "") != "stored")
      throw std::runtime_error(doc.path + " has status " +
                               doc.attrs.value("status", "?"));
  auto blobs = store.stats().blobs;
  if (blobs != static_cast<std::int64_t>(expected))
    throw std::runtime_error("the store holds " + std::to_string(blobs) +
                             " blobs for " + std::to_string(expected) +
                             " distinct uploads");
}

// --- small-document GETs -----------------------------------------------------

std::string doc_path(int i) { return "/bench/docs/d" + std::to_string(i); }

void seed_docs(db::Store& store, int docs) {
  std::vector<db::WriteOp> ops;
  for (int i = 0; i < docs; ++i)
    ops.push_back(db::WriteOp::put(
        doc_path(i), "bench",
        db::Json{{"i", i},
                 {"name", "capture-" + std::to_string(i)},
                 {"status", "new"},
                 {"gps", {{"lat", 48.137 + i * 1e-6}, {"lon", 11.575}}}}));
  store.batch(ops);
}

// One client's GETs, cycling over the documents from an offset of its own.
void get_all(const Config& cfg, int client, http::Client& http,
             std::vector<double>& latency_ms, Failures& failures) {
  for (int k = 0; k < cfg.gets_per_client; ++k) {
    int i = (client * cfg.gets_per_client + k) % cfg.docs;
    auto result = timed_request(http, "GET", "/v1/docs" + doc_path(i), "", {},
                                latency_ms, failures);
    if (!result) continue;
    // The first answer is parsed in full; the others only by status.
    bool ok = result->status == 200 &&
              (k > 0 || result->json().value("path", "") == doc_path(i));
    if (!ok)
      failures.record("HTTP " + std::to_string(result->status),
                      "GET " + doc_path(i) + ": " + excerpt(result->body));
  }
}

void measure_gets(const Fixture& fx, const Config& cfg, int clients,
                  Results& out) {
  Failures failures;
  PhaseTiming t = run_phase(
      fx, "GET /v1/docs/*", clients,
      [&](int c, http::Client& http, std::vector<double>& latency_ms) {
        get_all(cfg, c, http, latency_ms, failures);
      },
      failures);
  failures.throw_if_any("small-document GETs, " + label(clients),
                        clients * cfg.gets_per_client);
  out.add("small-document GETs, " + label(clients), "requests/s",
          clients * cfg.gets_per_client / t.seconds);
  add_latency("GET", clients, t, out);
}

// --- one run -----------------------------------------------------------------

void run_once(const Config& cfg, const std::vector<Image>& images, int run,
              Results& out) {
  arscout::bench::measure_fdatasync(cfg.tmp_dir, out);
  auto fx = start_fixture(cfg, run);
  std::string run_tag = "r" + std::to_string(run);
  // 1 client: each image once, for the latency without queueing.
  UploadPlan solo{images, run_tag + "-solo", static_cast<int>(images.size())};
  measure_uploads(*fx, solo, 1, out);
  UploadPlan many{images, run_tag + "-multi", cfg.uploads_per_client};
  measure_uploads(*fx, many, cfg.clients, out);
  verify_captures(*fx->store,
                  images.size() + static_cast<std::size_t>(cfg.clients) *
                                      cfg.uploads_per_client);
  seed_docs(*fx->store, cfg.docs);
  measure_gets(*fx, cfg, 1, out);
  measure_gets(*fx, cfg, cfg.clients, out);
}

// --- output ------------------------------------------------------------------

std::string size_range(const std::vector<Image>& images) {
  auto [lo, hi] = std::minmax_element(images.begin(), images.end(),
                                      [](const Image& a, const Image& b) {
                                        return a.bytes.size() < b.bytes.size();
                                      });
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.2f-%.2f MB", lo->bytes.size() / 1e6,
                hi->bytes.size() / 1e6);
  return buf;
}

void print_table(const Config& cfg, const std::vector<Image>& images,
                 const Results& results) {
  std::printf(
      "ingest_bench: backend=%s runs=%d clients=%d uploads=%dx%d "
      "(%zu JPEGs, %s) gets=%dx%d docs=%d\n",
      arscout::bench::backend_name(cfg.url).c_str(), cfg.runs, cfg.clients,
      cfg.clients, cfg.uploads_per_client, images.size(),
      size_range(images).c_str(), cfg.clients, cfg.gets_per_client, cfg.docs);
  arscout::bench::print_metrics(results);
  std::printf("load after: %s (1/5/15 min)\n",
              arscout::bench::load_average().c_str());
}

std::string default_data_dir() {
  const char* env = std::getenv("ARSCOUT_SHARED_DATA");
  if (env && *env) return env;
  return std::string(ARSCOUT_SOURCE_DIR) + "/../shared/data";
}

void add_options(CLI::App& app, Config& cfg) {
  app.add_option("--db", cfg.url,
                 "sqlite: (fresh file per run under --tmp-dir) or "
                 "postgresql://... (fresh database per run on that server)")
      ->required();
  app.add_option("--runs", cfg.runs, "runs; figures are their median")
      ->check(CLI::PositiveNumber);
  app.add_option("--clients", cfg.clients, "concurrent client threads")
      ->check(CLI::PositiveNumber);
  app.add_option("--uploads-per-client", cfg.uploads_per_client,
                 "POST /v1/captures per client")
      ->check(CLI::PositiveNumber);
  app.add_option("--gets-per-client", cfg.gets_per_client,
                 "GET /v1/docs/... per client")
      ->check(CLI::PositiveNumber);
  app.add_option("--docs", cfg.docs, "small documents the GETs cycle over")
      ->check(CLI::PositiveNumber);
  app.add_option("--data-dir", cfg.data_dir,
                 "the shared image data (default $ARSCOUT_SHARED_DATA, else "
                 "../shared/data beside the source tree)")
      ->check(CLI::ExistingDirectory);
  app.add_option("--tmp-dir", cfg.tmp_dir,
                 "where fresh SQLite files go and fdatasync is timed")
      ->check(CLI::ExistingDirectory);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"ingest_bench: HTTP upload and GET throughput and latency"};
  Config cfg;
  const char* tmp = std::getenv("TMPDIR");
  cfg.tmp_dir = tmp && *tmp ? tmp : "/tmp";
  cfg.data_dir = default_data_dir();
  add_options(app, cfg);
  CLI11_PARSE(app, argc, argv);
  arscout::bench::configure_logging("ingest_bench");
  try {
    std::printf("%s", arscout::bench::machine_summary().c_str());
    auto images = load_corpus(cfg.data_dir);
    Results results;
    for (int run = 0; run < cfg.runs; ++run) {
      std::fprintf(stderr, "ingest_bench: run %d/%d\n", run + 1, cfg.runs);
      run_once(cfg, images, run, results);
    }
    print_table(cfg, images, results);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ingest_bench: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
