#include "replay_support.h"

#include <algorithm>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <thread>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "arscout/engine/ply.h"
#include "arscout/engine/service.h"
#include "test_stores.h"

namespace arscout::replay {

namespace fs = std::filesystem;
using db::Json;

std::string table(const std::vector<Row>& rows) {
  std::ostringstream out;
  out << std::left << std::setw(40) << "statistic" << std::setw(14) << "got"
      << "expected\n";
  for (const Row& r : rows)
    out << std::setw(40) << r.name << std::setw(14) << r.got << "[" << r.min
        << ", " << r.max << "]" << (r.ok() ? "" : "   <-- FAILS") << "\n";
  return out.str();
}

void expect_rows_within(const std::vector<Row>& rows) {
  const bool all_ok = std::all_of(rows.begin(), rows.end(),
                                  [](const Row& row) { return row.ok(); });
  // Printed on success too: the log is where the measured figures are read
  // when the ranges are revised.
  std::cout << table(rows);
  EXPECT_TRUE(all_ok) << "\n" << table(rows);
}

std::string recorded_session(const std::string& dir, const std::string& name) {
  const fs::path session = fs::path(dir) / (name + ".session");
  if (!fs::exists(fs::path(dir) / "ready") || !fs::exists(session)) {
    const std::string why = "no recorded " + name + " session in " + dir +
                            " (its record_session.sh fixture failed?)";
    if (testing::in_ci()) ADD_FAILURE() << why;
    std::cout << "SKIP: " << why << std::endl;
    return "";
  }
  return session.string();
}

Replayed replay_with_engine(const std::string& session,
                            engine::WorkerOptions options,
                            const ingest::ReplayOptions& replay,
                            std::chrono::seconds timeout) {
  Replayed out;
  out.store = db::Store::open(testing::fresh_sqlite_url());
  // What CI can afford, and what the viewer fixture's live engine ran at.
  options.dense_options.long_side = 480;
  const auto start = std::chrono::steady_clock::now();
  engine::EngineWorker worker(*out.store, options);
  worker.start();
  out.summary = ingest::replay_session(session, *out.store, replay);
  // wait_idle covers what was committed before it is called: every input,
  // now that the replay has returned, and the increments they cause.
  const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
      start + timeout - std::chrono::steady_clock::now());
  const bool idle = worker.wait_idle(std::max(left, left.zero()));
  worker.stop();
  out.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
          .count();
  const std::vector<db::Document> sites = out.store->list_children("/sites");
  out.sites = static_cast<int>(sites.size());
  if (!idle) return out;
  const auto registered = [](const db::Document& m) {
    return m.attrs.at("statistics").value("registered", 0);
  };
  for (const db::Document& site : sites) {
    auto model = out.store->get(site.path + "/model");
    if (!model || model->attrs.value("dense_state", "") != "current") continue;
    if (!out.model || registered(*model) > registered(*out.model))
      out.model = std::move(model);
  }
  return out;
}

Replayed replay_deterministically(const std::string& session,
                                  std::chrono::seconds timeout) {
  engine::WorkerOptions options;
  options.reconstruction.deterministic = true;
  ingest::ReplayOptions fast;
  fast.fast = true;
  Replayed r = replay_with_engine(session, options, fast, timeout);
  std::cout << "replay and engine: " << r.seconds << " s" << std::endl;
  return r;
}

namespace {

// "alice.0005.jpg" -> "0005.jpg": the capture id less the scout's space.
std::string photo_name(const std::string& capture_id) {
  return capture_id.substr(capture_id.find('.') + 1);
}

}  // namespace

std::map<std::string, eval::Pose> model_poses(const Json& model) {
  std::map<std::string, eval::Pose> poses;
  for (const Json& image : model.at("images")) {
    eval::Pose pose;
    pose.name = photo_name(image.at("id"));
    const auto q = image.at("qvec").get<std::array<double, 4>>();
    const auto t = image.at("tvec").get<std::array<double, 3>>();
    pose.R = Eigen::Quaterniond(q[0], q[1], q[2], q[3]).toRotationMatrix();
    pose.t = Eigen::Vector3d(t[0], t[1], t[2]);
    poses[pose.name] = pose;
  }
  return poses;
}

std::map<std::string, eval::GeoRow> model_positions(const Json& model) {
  std::map<std::string, eval::GeoRow> rows;
  for (const Json& image : model.at("images"))
    if (const auto g = image.find("geodetic"); g != image.end())
      rows[photo_name(image.at("id"))] = {g->at("lat").get<double>(),
                                          g->at("lon").get<double>(),
                                          g->at("alt").get<double>()};
  return rows;
}

std::map<std::string, eval::GeoRow> capture_fixes(db::Store& store) {
  std::map<std::string, eval::GeoRow> rows;
  for (const db::Document& capture : store.list_children("/captures"))
    if (const auto g = capture.attrs.find("gps"); g != capture.attrs.end())
      rows[photo_name(capture.path.substr(capture.path.rfind('/') + 1))] = {
          g->at("lat").get<double>(), g->at("lon").get<double>(),
          g->value("alt", 0.0)};
  return rows;
}

double median_horizontal_distance(std::map<std::string, eval::GeoRow> a,
                                  std::map<std::string, eval::GeoRow> b) {
  // On a common height the 3D distance of the evaluation library is the
  // horizontal one (to well under a millimetre over a street's length).
  for (auto* rows : {&a, &b})
    for (auto& [name, row] : *rows) row.alt = 0;
  int matched = 0;
  return eval::median_geo_distance(a, b, &matched);
}

double dense_point_count(db::Store& store, const db::Document& model) {
  return static_cast<double>(
      engine::load_dense_cloud(store, engine::dense_cloud_blobs(model)).size());
}

}  // namespace arscout::replay
