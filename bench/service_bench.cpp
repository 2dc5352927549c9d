// service_bench: insert-to-model latency of the engine service: for each
// capture, from the commit of its capture document to the commit of the
// first model version in which it is registered, and to the first version
// whose dense cloud includes its view, with photos stored as scouts walking
// a scene would store them.
//
//   service_bench [--scene DIR] [--scouts 1] [--interval 2] [--views N]
//                 [--split] [--toward] [--db URL] [--no-dense]
//                 [--per-capture] [--dense-new-coverage S]
//                 [--dense-long-side PX] [--site-radius M] [--settle S]
//                 [--max-features N] [--refine-interval S]
//                 [--gc-interval S] [--gc-min-age S]
//                 [--dense-tile-interval S]
//
// DIR holds images/*.jpg, images/K.txt and gps.csv: a Strecha scene
// (fountain-P11 by default) or a rendered block walk (`arscout render-site
// --scene block`); without gps.csv each photo's fix is its EXIF GPS, and
// without K.txt the engine takes the camera from the EXIF focal length, as
// for a phone's uploads (opensfm/lund). The photos, in name order, are dealt
// round-robin to
// --scouts scouts; each scout stores one every --interval seconds, the
// scouts evenly staggered, so the engine sees the walk in order at
// scouts / interval photos per second (two scouts covering both sides of
// one street walk together). With --split each scout walks a contiguous
// part of the walk instead (scout k the k-th of --scouts equal parts), all
// at once, so they start in different places; with --toward as well, every
// second scout walks its part backwards, so that two scouts on the first
// half of a loop walk (--views half the rendered views) start at its two
// ends, half the block apart, and walk toward each other. The report then
// adds, per scout, the share registered and its latency, and when the
// sites' components merged. A scene with gt_dense_cameras/ (a rendered
// one) also gets each site's camera accuracy after a similarity fit, with
// its worst cameras. --settle bounds the wait for the worker to go idle
// after the last photo (a background refinement may run on for minutes).
//
// At the end it prints what the walk left stored against the photos' own
// bytes, and what the blob collector (run as `arscout serve` runs it:
// every --gc-interval, sparing blobs younger than --gc-min-age) removed;
// --gc-interval 0 --refine-interval 0 --dense-tile-interval 0 is the
// service before issue 37.
//
// The worker runs in this process on the store (as `arscout serve
// --with-engine` does); captures are written as the API writes them. Times
// are the store's commit times (Change::time_us). A model version is read
// when its change is seen, so a capture first registered in a version that
// was already overtaken is charged the later one: latencies are upper
// bounds. Printed: latency percentiles over all photos and over the walk's
// early and late windows (bench_support.h), the cost of increments by the
// number of photos folded into them (a backlog drains when k photos cost
// about k times one), this process's peak resident memory and the engine
// state stored per registered photo.
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <mutex>
#include <sstream>
#include <thread>

#include <CLI/CLI.hpp>
#include <Eigen/Geometry>

#include "arscout/db/blob_collector.h"
#include "arscout/db/store.h"
#include "arscout/documents/capture.h"
#include "arscout/documents/model.h"
#include "arscout/documents/site.h"
#include "arscout/engine/camera.h"
#include "arscout/engine/image_size.h"
#include "arscout/engine/service.h"
#include "arscout/metadata/gps.h"
#include "bench_support.h"
#include "model_eval.h"
#include "progress_log.h"

#ifndef ARSCOUT_SOURCE_DIR
#define ARSCOUT_SOURCE_DIR "."
#endif

namespace {

namespace fs = std::filesystem;
namespace bench = arscout::bench;
using arscout::db::Json;
using arscout::eval::percentile;

struct Options {
  std::string url;
  std::string scene =
      std::string(ARSCOUT_SOURCE_DIR) + "/../shared/data/strecha/fountain-P11";
  double interval_s = 2;
  int scouts = 1;
  int views = 0;  // all
  bool split = false;
  bool toward = false;
  bool no_dense = false;
  bool mesh = false;  // WorkerOptions::mesh
  double mesh_budget = arscout::engine::WorkerOptions{}.mesh_budget_seconds;
  int prepare_ahead = arscout::engine::WorkerOptions{}.prepare_ahead;
  int increment_captures = arscout::engine::WorkerOptions{}.increment_captures;
  bool per_capture = false;
  // How long to wait, after the last photo, for the worker to go idle (the
  // background refinement and the dense re-fusing it causes may run on).
  double settle_s = 1800;
  double site_radius_m = 50;
  double new_coverage = 0;  // DenseOptions::new_coverage_share
  int dense_long_side = arscout::engine::DenseOptions{}.long_side;
  int max_features = arscout::engine::ReconstructionOptions{}.max_features;
  int match_features = arscout::engine::ReconstructionOptions{}.match_features;
  // DenseOptions::sweep_budget and refuse_budget_sweeping (0 and -1: the
  // service's lane defaults).
  int sweep_budget = 0;
  int refuse_budget_sweeping = -1;
  int catch_up_backlog = -1;  // DenseOptions::catch_up_backlog
  // As `arscout serve --with-engine` runs (docs/service.md, "Storage"):
  // refinement versions at most one per this many seconds, and the blob
  // collector every gc_interval_s with a grace of gc_min_age_s (0: off,
  // as before issue 37), the dense tiles stored at most every
  // dense_tile_interval_s while the lane has work left over.
  double refine_interval_s = 10;
  double gc_interval_s = 60;
  double gc_min_age_s = 300;
  double dense_tile_interval_s = 30;
};

struct Photo {
  fs::path path;
  std::string id;
  int scout = 0;
  double at_s = 0;  // when it is stored, from the start
};

// One model version that took in new captures.
struct IncrementSeen {
  int added = 0;
  double sparse_s = 0;
};

// What the model feed showed, keyed by capture id.
// A site's components as one model version showed them.
struct ComponentsSeen {
  double at_s = 0;  // since the first photo was stored
  std::string site;
  size_t components = 0;
};

struct Observed {
  std::mutex mutex;
  std::int64_t start_us = 0;  // the first photo's commit
  std::vector<ComponentsSeen> components;
  std::map<std::string, std::int64_t> stored_us;
  std::map<std::string, std::int64_t> registered_us;
  std::map<std::string, std::int64_t> dense_us;
  // The rule before images said it: registered in a model whose dense
  // state is not "pending" (kept to compare with earlier figures).
  std::map<std::string, std::int64_t> current_us;
  std::vector<IncrementSeen> increments;
  int versions = 0;  // model versions seen, all kinds
  // With --mesh: each dense phase's mesh seconds (its log line), with the
  // photos stored when it ended.
  int photos_stored = 0;
  std::vector<std::pair<int, double>> mesh_phases;
  // The last mesh phase: when it ended (microseconds since the epoch) and
  // how many tiles it left stale.
  std::int64_t last_mesh_us = 0;
  long last_mesh_left = 0;
};

std::int64_t now_us() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

// The mesh seconds of `line` when it is a dense phase's ("mesh N triangles
// (k tiles made, L left, n of them new, c columns read, MS ms)"), and the
// tiles it left in *left; negative otherwise.
double mesh_seconds(const std::string& line, long* left) {
  const auto at = line.find(", mesh ");
  if (at == std::string::npos) return -1;
  const auto made = line.find("tiles made, ", at);
  const auto ms = line.find(" columns read, ", at);
  if (made == std::string::npos || ms == std::string::npos) return -1;
  *left = std::atol(line.c_str() + made + 12);
  return std::atof(line.c_str() + ms + 15) / 1000;
}

// Per photo (in storing order), the mesh seconds of the first dense phase
// that ended after it was stored: what meshing added before the surface
// could show it. NaN when none did.
std::vector<double> mesh_cost_per_photo(const Observed& seen, std::size_t n) {
  std::vector<double> cost(n, std::numeric_limits<double>::quiet_NaN());
  for (std::size_t i = 0; i < n; ++i)
    for (const auto& [stored, seconds] : seen.mesh_phases)
      if (stored >= static_cast<int>(i) + 1) {
        cost[i] = seconds;
        break;
      }
  return cost;
}

std::string read_file(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream bytes;
  bytes << in.rdbuf();
  return bytes.str();
}

std::vector<Photo> walk_photos(const Options& o) {
  std::vector<fs::path> paths;
  for (const auto& e : fs::directory_iterator(o.scene + "/images"))
    if (e.path().extension() == ".jpg") paths.push_back(e.path());
  std::sort(paths.begin(), paths.end());
  if (o.views > 0 && paths.size() > static_cast<size_t>(o.views))
    paths.resize(static_cast<size_t>(o.views));
  std::vector<Photo> photos;
  const size_t n = paths.size();
  const size_t scouts = static_cast<size_t>(o.scouts);
  for (size_t i = 0; i < n; ++i) {
    // Round robin, or each scout its own part (the k-th of `scouts`).
    const size_t scout = o.split ? i * scouts / n : i % scouts;
    const size_t begin = (scout * n + scouts - 1) / scouts;
    const size_t end = ((scout + 1) * n + scouts - 1) / scouts;
    size_t step = o.split ? i - begin : i / scouts;
    if (o.split && o.toward && scout % 2 == 1) step = end - 1 - i;
    photos.push_back({paths[i], paths[i].stem().string(),
                      static_cast<int>(scout),
                      o.interval_s * (double(step) + double(scout) / scouts)});
  }
  // Stored in the order they are taken.
  std::stable_sort(
      photos.begin(), photos.end(),
      [](const Photo& a, const Photo& b) { return a.at_s < b.at_s; });
  return photos;
}

// Where the photos' fixes and camera come from: gps.csv and images/K.txt
// when the scene has them (a Strecha or rendered scene), else each photo's
// EXIF, as the API reads an upload's (a phone walk such as opensfm/lund):
// its GPS, and its focal length for the engine's intrinsics.
struct SceneMetadata {
  bool has_camera = false;  // images/K.txt, stored as /cameras/bench
  std::map<std::string, arscout::metadata::GpsFix> fixes;  // by file name
};

SceneMetadata read_metadata(const Options& o,
                            const std::vector<Photo>& photos) {
  SceneMetadata meta;
  meta.has_camera = fs::exists(o.scene + "/images/K.txt");
  if (fs::exists(o.scene + "/gps.csv")) {
    meta.fixes = arscout::metadata::read_gps_csv(o.scene + "/gps.csv");
    return meta;
  }
  for (const Photo& photo : photos) {
    const auto exif = arscout::metadata::read_exif_file(photo.path.string());
    if (!exif.gps)
      throw std::runtime_error(photo.path.string() +
                               ": no gps.csv in the scene and no GPS in the "
                               "photo's EXIF");
    meta.fixes[photo.path.filename().string()] = *exif.gps;
  }
  return meta;
}

void put_camera(arscout::db::Store& store, const Options& o,
                const Photo& first) {
  const auto size = arscout::engine::read_image_size(read_file(first.path));
  if (!size) throw std::runtime_error("cannot read " + first.path.string());
  const auto K = arscout::engine::read_k_matrix(o.scene + "/images/K.txt",
                                                size->width, size->height);
  store.put("/cameras/bench", "camera", arscout::documents::to_json(K));
}

void on_model(arscout::db::Store& store, const arscout::db::Change& change,
              Observed& seen) {
  auto doc = store.get(change.path);
  if (!doc) return;
  const Json& attrs = doc->attrs;
  const Json captures = attrs.value("captures", Json::object());
  const Json increment = attrs.value("increment", Json::object());
  const int added =
      static_cast<int>(increment.value("added", Json::array()).size());
  std::lock_guard lock(seen.mutex);
  ++seen.versions;
  // The sparse phase's version: the dense phase's names the same captures
  // but spent no sparse time.
  const double sparse_s =
      attrs.value("timings", Json::object()).value("sparse_s", 0.0);
  if (added > 0 && sparse_s > 0) seen.increments.push_back({added, sparse_s});
  const size_t components = attrs.value("components", Json::array()).size();
  if (seen.start_us > 0)
    seen.components.push_back({double(change.time_us - seen.start_us) / 1e6,
                               attrs.value("site", std::string()), components});
  // Each image says whether the cloud covers its view (its depth map or
  // its key views'); a model without that says it for all at once.
  const bool dense_current = attrs.value("dense_state", "") != "pending";
  for (const Json& image : attrs.value("images", Json::array())) {
    const std::string id = image.value("id", "");
    if (image.value("dense", dense_current))
      seen.dense_us.emplace(id, change.time_us);
  }
  for (const auto& [id, status] : captures.items()) {
    if (status != arscout::documents::to_string(
                      arscout::documents::CaptureStatus::kRegistered))
      continue;
    seen.registered_us.emplace(id, change.time_us);
    if (dense_current) seen.current_us.emplace(id, change.time_us);
  }
}

// The capture document as the API writes one (documents::Capture), with
// the camera stored for the scene or, without one, the photo's EXIF.
void store_photo(arscout::db::Store& store, const Photo& photo,
                 const SceneMetadata& meta, Observed& seen) {
  arscout::documents::Capture capture;
  capture.scout = "scout-" + std::to_string(photo.scout + 1);
  capture.format = "jpeg";
  capture.status = arscout::documents::CaptureStatus::kStored;
  capture.gps = meta.fixes.at(photo.path.filename().string());
  capture.filename = photo.path.filename().string();
  if (meta.has_camera) {
    capture.camera = "bench";
  } else {
    const auto exif = arscout::metadata::read_exif_file(photo.path.string());
    capture.exif = {exif.focal_35mm, exif.focal_mm, exif.make, exif.model};
  }
  arscout::db::WriteOp op =
      arscout::db::WriteOp::put("/captures/" + photo.id, "capture",
                                arscout::documents::to_json(capture), 0);
  op.blobs =
      arscout::db::BlobRefs{{"image", store.put_blob(read_file(photo.path))}};
  store.batch({op});
  const auto doc = store.get("/captures/" + photo.id);
  std::lock_guard lock(seen.mutex);
  seen.stored_us[photo.id] = doc->created_us;
  if (seen.start_us == 0) seen.start_us = doc->created_us;
}

// Latencies in walk order (seconds); NaN for a capture never reached.
std::vector<double> latencies(const std::vector<Photo>& photos,
                              const std::map<std::string, std::int64_t>& from,
                              const std::map<std::string, std::int64_t>& to) {
  std::vector<double> result;
  for (const Photo& p : photos) {
    const auto a = from.find(p.id), b = to.find(p.id);
    result.push_back(a == from.end() || b == to.end()
                         ? std::nan("")
                         : double(b->second - a->second) / 1e6);
  }
  return result;
}

// The finite values of photos first..last (1-based, inclusive).
std::vector<double> window(const std::vector<double>& v, int first, int last) {
  std::vector<double> out;
  for (int i = first; i <= last && i <= static_cast<int>(v.size()); ++i)
    if (std::isfinite(v[i - 1])) out.push_back(v[i - 1]);
  return out;
}

void print_latency(const char* what, const std::vector<double>& v) {
  const bench::WalkWindows w = bench::walk_windows(static_cast<int>(v.size()));
  const auto all = window(v, 1, static_cast<int>(v.size()));
  std::printf("%s: %zu of %zu reached; p50 %.2f s, p95 %.2f s, max %.2f s",
              what, all.size(), v.size(), percentile(all, .5),
              percentile(all, .95), percentile(all, 1.0));
  if (w.first_begin > w.first_end) {  // too short a walk for the windows
    std::printf("\n");
    return;
  }
  const double early = percentile(window(v, w.first_begin, w.first_end), .95);
  const double late = percentile(window(v, w.last_begin, w.last_end), .95);
  std::printf("; p95 photos %d-%d %.2f s, %d-%d %.2f s, ratio %.2f\n",
              w.first_begin, w.first_end, early, w.last_begin, w.last_end, late,
              late / early);
}

// The sparse cost of an increment by the photos folded into it, against k
// times the median one-photo increment.
void print_folding(const std::vector<IncrementSeen>& increments) {
  std::map<int, std::vector<double>> by_k;
  for (const IncrementSeen& i : increments) by_k[i.added].push_back(i.sparse_s);
  const double one = by_k.count(1) ? bench::median(by_k.at(1)) : std::nan("");
  std::printf(
      "\n| photos folded | increments | sparse s, median | per photo | vs k x "
      "one-photo |\n|---|---|---|---|---|\n");
  for (const auto& [k, costs] : by_k) {
    const double m = bench::median(costs);
    std::printf("| %d | %zu | %.2f | %.2f | %.2f |\n", k, costs.size(), m,
                m / k, m / (k * one));
  }
}

// Bytes stored under a site for the engine: the state blob, the features
// documents and the depth maps.
void print_state_bytes(arscout::db::Store& store, int registered) {
  std::int64_t state = 0, features = 0, depth = 0;
  const auto blob_size = [&](const arscout::db::Document& doc) {
    std::int64_t bytes = 0;
    for (const auto& [name, sha] : doc.blobs)
      if (auto info = store.blob_info(sha)) bytes += info->size;
    return bytes;
  };
  for (const auto& site : store.list_children("/sites")) {
    if (auto engine = store.get(site.path + "/engine"))
      state += blob_size(*engine);
    for (const auto& doc : store.list_children(site.path + "/features"))
      features += blob_size(doc);
    for (const auto& doc : store.list_children(site.path + "/depth"))
      depth += blob_size(doc);
  }
  const double n = std::max(1, registered);
  std::printf(
      "engine state stored: state blob %.1f MB (%.1f KB per registered "
      "photo), features %.1f MB (%.0f KB per photo), depth maps %.1f MB "
      "(%.0f KB per photo)\n",
      state / 1e6, state / n / 1e3, features / 1e6, features / n / 1e3,
      depth / 1e6, depth / n / 1e3);
}

// Per scout: the share of its photos registered, and their latency.
void print_scouts(const Options& o, const std::vector<Photo>& photos,
                  const std::vector<double>& registered) {
  std::printf(
      "\n| scout | photos | registered | latency p50 | p95 | max |\n"
      "|---|---|---|---|---|---|\n");
  for (int scout = 0; scout < o.scouts; ++scout) {
    std::vector<double> mine;
    size_t count = 0;
    for (size_t i = 0; i < photos.size(); ++i) {
      if (photos[i].scout != scout) continue;
      ++count;
      if (std::isfinite(registered[i])) mine.push_back(registered[i]);
    }
    std::printf(
        "| %d | %zu | %.1f %% | %.2f s | %.2f s | %.2f s |\n", scout + 1, count,
        100.0 * mine.size() / std::max<size_t>(1, count), percentile(mine, .5),
        percentile(mine, .95), percentile(mine, 1.0));
  }
}

// When each site's component count changed (a new one, or a merge), and
// at the end the sites with models, a site taken into another (its
// document's merged_into) named as merged, not as a site.
void print_components(arscout::db::Store& store, const Observed& seen) {
  std::map<std::string, size_t> last;
  std::printf("\ncomponents over time (s since the first photo):");
  for (const ComponentsSeen& c : seen.components) {
    auto it = last.find(c.site);
    if (it != last.end() && it->second == c.components) continue;
    std::printf(
        " %.0f s %s: %zu%s;", c.at_s, c.site.c_str(), c.components,
        it != last.end() && it->second > c.components ? " (merged)" : "");
    last[c.site] = c.components;
  }
  std::map<std::string, std::string> merged;  // site -> the one it joined
  for (const auto& doc : store.list_children("/sites")) {
    const std::string id = doc.path.substr(doc.path.rfind('/') + 1);
    const auto site = arscout::documents::site_from_json(doc.attrs, id);
    if (!site.merged_into.empty()) merged[id] = site.merged_into;
  }
  std::string sites, joined;
  size_t live = 0;
  for (const auto& [site, components] : last) {
    if (merged.count(site)) {
      joined += " " + site + " into " + merged.at(site);
      continue;
    }
    ++live;
    sites += " " + site + " (" + std::to_string(components) + " component" +
             (components == 1 ? ")" : "s)");
  }
  std::printf("\nat the end: %zu site(s) with a model:%s\n", live,
              sites.c_str());
  if (!joined.empty()) std::printf("merged sites:%s\n", joined.c_str());
}

// Each live site's cameras against the scene's exact truth (a rendered
// scene's gt_dense_cameras), after a similarity fit; nothing without one.
void print_accuracy(arscout::db::Store& store, const Options& o) {
  const std::string truth_dir = o.scene + "/gt_dense_cameras";
  if (!fs::is_directory(truth_dir)) return;
  const auto truth = arscout::eval::read_strecha_ground_truth(truth_dir);
  for (const auto& site : store.list_children("/sites")) {
    const auto doc = store.get(site.path + "/model");
    if (!doc) continue;
    const auto model = arscout::documents::model_from_json(doc->attrs);
    std::map<std::string, arscout::eval::Pose> poses;
    for (const auto& image : model.images) {
      arscout::eval::Pose pose;
      pose.name = image.id + ".jpg";
      const auto& q = image.qvec;
      pose.R = Eigen::Quaterniond(q[0], q[1], q[2], q[3])
                   .normalized()
                   .toRotationMatrix();
      pose.t = Eigen::Vector3d(image.tvec[0], image.tvec[1], image.tvec[2]);
      poses[pose.name] = pose;
    }
    if (poses.size() < 3) continue;
    const auto c = arscout::eval::compare_to_ground_truth(poses, truth);
    std::printf(
        "accuracy %s: %d cameras, centre error after a similarity fit: "
        "median %.2f cm, max %.2f cm; rotation median %.3f deg (%.3f deg "
        "between cameras, a common tilt taken out)\n",
        site.path.c_str(), c.matched, c.median_centre_error * 100,
        c.max_centre_error * 100, c.median_rotation_error_deg,
        c.median_relative_rotation_error_deg);
    // The worst, and which component each is in: a bad merge shows as one
    // component's cameras off together.
    std::map<std::string, int> component;
    for (const auto& image : model.images)
      component[image.id + ".jpg"] = image.component.value_or(-1);
    std::vector<arscout::eval::CameraError> worst = c.cameras;
    std::sort(worst.begin(), worst.end(), [](const auto& a, const auto& b) {
      return a.centre_error > b.centre_error;
    });
    worst.resize(std::min<size_t>(worst.size(), 8));
    std::printf("  worst:");
    for (const auto& e : worst)
      std::printf(" %s %.1f cm (component %d);", e.name.c_str(),
                  e.centre_error * 100, component[e.name]);
    std::printf("\n");
  }
}

// What the walk left in the store against the photos' own bytes, and what
// the blob collector removed on its way (issue 37: at most 3x).
void print_storage(arscout::db::Store& store, const std::vector<Photo>& photos,
                   const arscout::db::BlobCollector& collector, int versions) {
  std::int64_t photo_bytes = 0;
  for (const Photo& photo : photos)
    photo_bytes += static_cast<std::int64_t>(fs::file_size(photo.path));
  const arscout::db::StoreStats stats = store.stats();
  const arscout::db::BlobCollectorStats gc = collector.stats();
  const double n = static_cast<double>(std::max<size_t>(1, photos.size()));
  std::printf(
      "stored: %.1f MB of blobs (%lld) for %.1f MB of photos: %.2f MB per "
      "photo, %.2fx the photos; the collector ran %lld times and removed "
      "%lld blobs (%.1f MB); %d model versions seen\n",
      stats.blob_bytes / 1e6, static_cast<long long>(stats.blobs),
      photo_bytes / 1e6, stats.blob_bytes / n / 1e6,
      static_cast<double>(stats.blob_bytes) /
          static_cast<double>(std::max<std::int64_t>(1, photo_bytes)),
      static_cast<long long>(gc.runs), static_cast<long long>(gc.blobs_removed),
      gc.bytes_removed / 1e6, versions);
}

void print_report(arscout::db::Store& store, const Options& o,
                  const std::vector<Photo>& photos, Observed& seen) {
  std::lock_guard lock(seen.mutex);
  const auto registered = latencies(photos, seen.stored_us, seen.registered_us);
  const auto dense = latencies(photos, seen.stored_us, seen.dense_us);
  if (o.per_capture) {
    std::printf("| capture | scout | registered (s) | dense (s) |\n");
    std::printf("|---|---|---|---|\n");
    for (size_t i = 0; i < photos.size(); ++i)
      std::printf("| %s | %d | %.2f | %.2f |\n", photos[i].id.c_str(),
                  photos[i].scout + 1, registered[i], dense[i]);
  }
  std::printf("\n%s", bench::machine_summary().c_str());
  std::printf(
      "%zu photos from %s, %d scout(s)%s, one every %.1f s each, "
      "dense %s (long side %d px, new coverage %.2f)\n",
      photos.size(), o.scene.c_str(), o.scouts,
      o.split ? (o.toward ? " each on its part, toward each other"
                          : " each on its part of the walk")
              : " sharing the walk",
      o.interval_s, o.no_dense ? "off" : "on", o.dense_long_side,
      o.new_coverage);
  print_latency("to a model registering it", registered);
  print_scouts(o, photos, registered);
  print_components(store, seen);
  if (!o.no_dense) {
    print_latency("to its dense cloud", dense);
    print_latency("to a model with dense_state current (the earlier rule)",
                  latencies(photos, seen.stored_us, seen.current_us));
  }
  if (o.mesh) {
    std::printf("%zu dense phases made the surface\n", seen.mesh_phases.size());
    print_latency("mesh seconds of the phase that followed it",
                  mesh_cost_per_photo(seen, photos.size()));
    std::int64_t last_stored = 0;
    for (const auto& [id, us] : seen.stored_us)
      last_stored = std::max(last_stored, us);
    std::printf(
        "the last mesh phase ended %.1f s after the last photo was stored, "
        "leaving %ld tiles stale\n",
        (seen.last_mesh_us - last_stored) / 1e6, seen.last_mesh_left);
  }
  print_folding(seen.increments);
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  std::printf("\npeak RSS of the process (worker and store): %.0f MiB\n",
              usage.ru_maxrss / 1024.0);
  print_state_bytes(store, static_cast<int>(seen.registered_us.size()));
  print_accuracy(store, o);
}

void run(const Options& o) {
  const std::vector<Photo> photos = walk_photos(o);
  if (photos.empty())
    throw std::runtime_error("no photos in " + o.scene + "/images");
  auto store = arscout::db::Store::open(o.url);
  const SceneMetadata meta = read_metadata(o, photos);
  if (meta.has_camera) put_camera(*store, o, photos.front());
  Observed seen;
  auto models = store->subscribe(
      "/sites/*/model", store->last_seq(),
      [&](const arscout::db::Change& c) { on_model(*store, c, seen); });
  arscout::engine::WorkerOptions options;
  options.dense = !o.no_dense;
  options.prepare_ahead = o.prepare_ahead;
  options.increment_captures = o.increment_captures;
  options.site_radius_m = o.site_radius_m;
  options.dense_options.new_coverage_share = o.new_coverage;
  options.dense_options.long_side = o.dense_long_side;
  options.reconstruction.max_features = o.max_features;
  options.reconstruction.match_features = o.match_features;
  options.dense_options.sweep_budget = o.sweep_budget;
  options.dense_options.refuse_budget_sweeping = o.refuse_budget_sweeping;
  options.dense_options.catch_up_backlog = o.catch_up_backlog;
  options.mesh = o.mesh;
  options.mesh_budget_seconds = o.mesh_budget;
  options.progress = [&seen](const std::string& line) {
    std::fprintf(stderr, "  %s\n", line.c_str());
    long left = 0;
    const double mesh = mesh_seconds(line, &left);
    if (mesh < 0) return;
    std::lock_guard lock(seen.mutex);
    seen.mesh_phases.push_back({seen.photos_stored, mesh});
    seen.last_mesh_us = now_us();
    seen.last_mesh_left = left;
  };
  options.refinement_interval = std::chrono::milliseconds(
      static_cast<std::int64_t>(o.refine_interval_s * 1000));
  options.dense_tile_interval = std::chrono::milliseconds(
      static_cast<std::int64_t>(o.dense_tile_interval_s * 1000));
  arscout::engine::EngineWorker worker(*store, options);
  arscout::db::BlobCollector collector(
      *store,
      {std::chrono::seconds(static_cast<std::int64_t>(o.gc_interval_s)),
       std::chrono::seconds(static_cast<std::int64_t>(o.gc_min_age_s))});
  worker.start();
  collector.start();
  const auto start = std::chrono::steady_clock::now();
  for (const Photo& photo : photos) {
    std::this_thread::sleep_until(
        start + std::chrono::milliseconds(static_cast<int>(1000 * photo.at_s)));
    store_photo(*store, photo, meta, seen);
    {
      std::lock_guard lock(seen.mutex);
      ++seen.photos_stored;
    }
    std::fprintf(stderr, "stored %s (scout %d)\n", photo.id.c_str(),
                 photo.scout + 1);
  }
  if (!worker.wait_idle(std::chrono::milliseconds(
          static_cast<std::int64_t>(o.settle_s * 1000))))
    std::fprintf(stderr, "still busy after --settle %.0f s: reporting now\n",
                 o.settle_s);
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  models->stop();
  worker.stop();
  collector.stop();
  print_report(*store, o, photos, seen);
  print_storage(*store, photos, collector, seen.versions);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Insert-to-model latency of the engine service"};
  Options o;
  app.add_option("--db", o.url, "store URL (default: a fresh SQLite file)");
  app.add_option("--scene", o.scene,
                 "images/*.jpg with images/K.txt and gps.csv, or with EXIF GPS "
                 "and focal length");
  app.add_option("--interval", o.interval_s,
                 "seconds between one scout's "
                 "photos")
      ->check(CLI::PositiveNumber);
  app.add_option("--scouts", o.scouts, "scouts sharing the walk")
      ->check(CLI::Range(1, 64));
  app.add_option("--views", o.views, "only the first N photos (0: all)")
      ->check(CLI::NonNegativeNumber);
  app.add_flag("--split", o.split,
               "each scout walks its own contiguous part of the walk, all "
               "at once (else they share it round robin)");
  app.add_flag("--toward", o.toward,
               "with --split: every second scout walks its part backwards");
  app.add_flag("--no-dense", o.no_dense, "sparse only");
  app.add_flag("--mesh", o.mesh,
               "the surface per mesh tile too (WorkerOptions::mesh): its "
               "seconds per dense phase, per photo");
  app.add_option("--mesh-budget", o.mesh_budget,
                 "as arscout serve's: seconds of mesh tile making per dense "
                 "phase (0: every changed tile)")
      ->capture_default_str();
  app.add_option("--prepare-ahead", o.prepare_ahead,
                 "photos decoded and described ahead of their increments "
                 "(0: inside them), as arscout engine's")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app.add_option("--increment-captures", o.increment_captures,
                 "captures one increment of a site takes at most, as arscout "
                 "engine's")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000));
  app.add_flag("--per-capture", o.per_capture, "a row per capture");
  app.add_option("--site-radius", o.site_radius_m,
                 "as arscout serve's: a capture joins a site whose footprint "
                 "is within this many metres")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--refine-interval", o.refine_interval_s,
                 "seconds: at most one refinement version per site this "
                 "often, as `arscout serve` (0: no bound)")
      ->capture_default_str();
  app.add_option("--dense-tile-interval", o.dense_tile_interval_s,
                 "seconds: a site's dense tiles stored at most this often "
                 "while its dense lane has work left over, as `arscout "
                 "serve` (0: every dense phase)")
      ->capture_default_str();
  app.add_option("--gc-interval", o.gc_interval_s,
                 "seconds between blob collections during the walk (0: none)")
      ->capture_default_str();
  app.add_option("--gc-min-age", o.gc_min_age_s,
                 "seconds of grace for a new blob before it may be collected")
      ->capture_default_str();
  app.add_option("--settle", o.settle_s,
                 "seconds to wait after the last photo for the worker to go "
                 "idle before reporting (the background refinement may run "
                 "on)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--dense-new-coverage", o.new_coverage,
                 "as arscout serve's (0: off)")
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--max-features", o.max_features,
                 "as arscout serve's: Harris corners per photo")
      ->capture_default_str()
      ->check(CLI::Range(100, 50000));
  app.add_option("--match-features", o.match_features,
                 "as arscout serve's: of those, the strongest an increment "
                 "matches")
      ->capture_default_str()
      ->check(CLI::Range(100, 50000));
  app.add_option("--dense-long-side", o.dense_long_side,
                 "as arscout serve's: dense working resolution, long side in "
                 "px")
      ->capture_default_str()
      ->check(CLI::Range(100, 10000));
  app.add_option("--sweep-budget", o.sweep_budget,
                 "views swept per dense phase (0: the lane's default, 2)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--refuse-budget-sweeping", o.refuse_budget_sweeping,
                 "moved maps re-fused by a dense phase that also sweeps "
                 "(-1: the lane's default, 2)")
      ->check(CLI::Range(-1, 1000));
  app.add_option("--dense-catch-up", o.catch_up_backlog,
                 "as arscout serve's: views waiting beyond which a dense "
                 "phase sweeps with planes twice as far apart (-1: the "
                 "lane's default, 2; 0: never)")
      ->check(CLI::Range(-1, 1000));
  CLI11_PARSE(app, argc, argv);
  if (o.url.empty()) {
    const fs::path dir = fs::temp_directory_path() / "arscout_service_bench";
    fs::remove_all(dir);
    fs::create_directories(dir);
    o.url = "sqlite:" + (dir / "bench.db").string();
  }
  try {
    run(o);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "service_bench: %s\n", e.what());
    return 1;
  }
  return 0;
}
