// service_bench: insert-to-model latency of the engine service (issue 6):
// for each capture, from the commit of its capture document to the commit
// of the first model version that includes it (registered), with photos
// stored at a fixed interval, as a scout walking fountain-P11 would.
//
//   service_bench [--db URL] [--interval 2] [--scene DIR] [--no-dense]
//
// The worker runs in this process on the store (as `arscout serve
// --with-engine` does); captures are written as the API writes them. Times
// are the store's commit times (Change::time_us). A model version is read
// when its change is seen, so a capture first registered in a version that
// was already overtaken is charged the later one: latencies are upper
// bounds.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>
#include <thread>

#include <CLI/CLI.hpp>

#include "arscout/db/store.h"
#include "arscout/engine/camera.h"
#include "arscout/engine/service.h"
#include "arscout/ingest/gps.h"

#ifndef ARSCOUT_SOURCE_DIR
#define ARSCOUT_SOURCE_DIR "."
#endif

namespace {

namespace fs = std::filesystem;
using arscout::db::Json;

std::string read_file(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream bytes;
  bytes << in.rdbuf();
  return bytes.str();
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const double rank = p * (v.size() - 1);
  const size_t lo = static_cast<size_t>(rank);
  const size_t hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (rank - lo) * (v[hi] - v[lo]);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Insert-to-model latency of the engine service"};
  std::string url, scene = std::string(ARSCOUT_SOURCE_DIR) +
                           "/../shared/data/strecha/fountain-P11";
  double interval_s = 2;
  bool no_dense = false;
  app.add_option("--db", url, "store URL (default: a fresh SQLite file)");
  app.add_option("--scene", scene, "a Strecha scene: images/, gps.csv");
  app.add_option("--interval", interval_s, "seconds between photos");
  app.add_flag("--no-dense", no_dense, "sparse only");
  CLI11_PARSE(app, argc, argv);
  if (url.empty()) {
    const fs::path dir = fs::temp_directory_path() / "arscout_service_bench";
    fs::remove_all(dir);
    fs::create_directories(dir);
    url = "sqlite:" + (dir / "bench.db").string();
  }
  auto store = arscout::db::Store::open(url);
  std::vector<fs::path> photos;
  for (const auto& e : fs::directory_iterator(scene + "/images"))
    if (e.path().extension() == ".jpg") photos.push_back(e.path());
  std::sort(photos.begin(), photos.end());
  if (photos.empty()) {
    std::fprintf(stderr, "no photos in %s/images\n", scene.c_str());
    return 2;
  }
  const auto fixes = arscout::ingest::read_gps_csv(scene + "/gps.csv");
  const auto K =
      arscout::engine::read_k_matrix(scene + "/images/K.txt", 3072, 2048);
  store->put("/cameras/bench", "camera",
             Json{{"fx", K.fx},
                  {"fy", K.fy},
                  {"cx", K.cx},
                  {"cy", K.cy},
                  {"width", K.width},
                  {"height", K.height},
                  {"source", "calibrated"}});

  std::mutex mutex;
  std::map<std::string, std::int64_t> stored_us;      // capture -> commit
  std::map<std::string, std::int64_t> registered_us;  // first model with it
  // First model with it whose dense cloud is current (includes its view).
  std::map<std::string, std::int64_t> dense_us;
  auto models = store->subscribe(
      "/sites/*/model", store->last_seq(),
      [&](const arscout::db::Change& change) {
        auto doc = store->get(change.path);
        if (!doc) return;
        const Json captures = doc->attrs.value("captures", Json::object());
        std::fprintf(stderr, "  model v%lld timings %s\n",
                     static_cast<long long>(doc->version),
                     doc->attrs.value("timings", Json()).dump().c_str());
        std::lock_guard lock(mutex);
        const bool dense_current =
            doc->attrs.value("dense_state", "") != "pending";
        for (const auto& [id, status] : captures.items()) {
          if (status != "registered") continue;
          if (!registered_us.count(id)) registered_us[id] = change.time_us;
          if (dense_current && !dense_us.count(id))
            dense_us[id] = change.time_us;
        }
      });

  arscout::engine::WorkerOptions options;
  options.dense = !no_dense;
  options.progress = [](const std::string& line) {
    std::fprintf(stderr, "  %s\n", line.c_str());
  };
  arscout::engine::EngineWorker worker(*store, options);
  worker.start();
  const auto start = std::chrono::steady_clock::now();
  for (size_t i = 0; i < photos.size(); ++i) {
    std::this_thread::sleep_until(
        start +
        std::chrono::milliseconds(static_cast<int>(1000 * interval_s * i)));
    const std::string id = photos[i].stem().string();
    const auto& fix = fixes.at(photos[i].filename().string());
    arscout::db::WriteOp op =
        arscout::db::WriteOp::put("/captures/" + id, "capture",
                                  Json{{"scout", "bench"},
                                       {"camera", "bench"},
                                       {"gps", arscout::ingest::to_json(fix)},
                                       {"status", "stored"}},
                                  0);
    op.blobs =
        arscout::db::BlobRefs{{"image", store->put_blob(read_file(photos[i]))}};
    store->batch({op});
    const auto doc = store->get("/captures/" + id);
    std::lock_guard lock(mutex);
    stored_us[id] = doc->created_us;
    std::fprintf(stderr, "stored %s\n", id.c_str());
  }
  worker.wait_idle(std::chrono::minutes(10));
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  models->stop();
  worker.stop();

  std::vector<double> all, after_initial, dense_all, dense_after_initial;
  std::printf(
      "| capture | to a model registering it (s) | to its dense cloud (s) "
      "|\n|---|---|---|\n");
  std::lock_guard lock(mutex);
  for (const auto& [id, t0] : stored_us) {
    if (!registered_us.count(id)) {
      std::printf("| %s | never registered | |\n", id.c_str());
      continue;
    }
    const double s = (registered_us.at(id) - t0) / 1e6;
    const double d = dense_us.count(id) ? (dense_us.at(id) - t0) / 1e6 : -1;
    all.push_back(s);
    if (all.size() > 2) after_initial.push_back(s);
    if (d >= 0) {
      dense_all.push_back(d);
      if (all.size() > 2) dense_after_initial.push_back(d);
    }
    std::printf("| %s | %.2f | %.2f |\n", id.c_str(), s, d);
  }
  char date[32];
  const std::time_t now = std::time(nullptr);
  std::strftime(date, sizeof date, "%Y-%m-%d %H:%M UTC", std::gmtime(&now));
  std::printf("\n%zu photos every %.1f s, dense %s, %s\n", photos.size(),
              interval_s, no_dense ? "off" : "on", date);
  std::printf(
      "to a model registering it, all captures: p50 %.2f s, p95 %.2f s\n",
      percentile(all, 0.5), percentile(all, 0.95));
  std::printf(
      "  from the third on (the first two wait for a third): p50 %.2f "
      "s, p95 %.2f s\n",
      percentile(after_initial, 0.5), percentile(after_initial, 0.95));
  if (!no_dense) {
    std::printf("to its dense cloud, all captures: p50 %.2f s, p95 %.2f s\n",
                percentile(dense_all, 0.5), percentile(dense_all, 0.95));
    std::printf("  from the third on: p50 %.2f s, p95 %.2f s\n",
                percentile(dense_after_initial, 0.5),
                percentile(dense_after_initial, 0.95));
  }
  return 0;
}
