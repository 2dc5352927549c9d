// `arscout summary`: the sites in a store, their model versions and
// registered counts, and (with --models DIR) their point clouds as PLY
// files: what the main job prints at its end.
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <thread>

#include "arscout/db/path.h"
#include "arscout/db/store.h"
#include "arscout/documents/capture.h"
#include "arscout/documents/model.h"
#include "arscout/documents/site.h"
#include "arscout/engine/ply.h"
#include "arscout/engine/service.h"
#include "cli_support.h"
#include "command_registry.h"
#include "commands.h"

namespace arscout::cli {
namespace {

namespace fs = std::filesystem;
using db::Json;

struct SummaryArgs {
  std::string db;
  std::string models;
  double wait_s = 0;
  std::string engine = "engine";
};

// Sites whose latest model still waits for its dense phase.
int sites_awaiting_dense(db::Store& store) {
  int behind = 0;
  for (const db::Document& site : store.list_children("/sites")) {
    auto model = store.get(site.path + "/model");
    if (model &&
        documents::model_from_json(model->attrs).dense_state == "pending")
      ++behind;
  }
  return behind;
}

// Waits until the engine's checkpoint covers every capture change (it has
// placed and, where it could, reconstructed them all), no model waits for
// its dense cloud, and both stay so for two seconds; false at the timeout.
bool wait_for_engine(db::Store& store, const SummaryArgs& a) {
  const auto start = std::chrono::steady_clock::now();
  auto elapsed = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() -
                                         start)
        .count();
  };
  int caught_up = 0;
  double next_report = 10;
  while (elapsed() < a.wait_s) {
    const std::int64_t target = store.last_change("/captures/*");
    const std::int64_t at = store.load_checkpoint(a.engine);
    const int dense_behind = sites_awaiting_dense(store);
    caught_up = at >= target && dense_behind == 0 ? caught_up + 1 : 0;
    if (caught_up >= 4) return true;
    if (elapsed() >= next_report) {
      std::cout << "waiting for engine '" << a.engine << "': at seq " << at
                << " of " << target;
      if (dense_behind > 0)
        std::cout << ", dense cloud to follow on " << dense_behind << " site"
                  << (dense_behind == 1 ? "" : "s");
      std::cout << " (" << static_cast<int>(elapsed()) << " s)" << std::endl;
      next_report += 10;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
  }
  return false;
}

// How many of the site's captures have each status.
std::map<std::string, int> capture_statuses(
    db::Store& store, const std::vector<std::string>& captures) {
  std::map<std::string, int> counts;
  for (const std::string& id : captures) {
    auto doc = store.get("/captures/" + id);
    if (!doc) {
      ++counts["missing"];
      continue;
    }
    // "?": no status, or a word of another version.
    const auto status = documents::capture_from_json(doc->attrs).status;
    ++counts[status ? to_string(*status) : "?"];
  }
  return counts;
}

void write_blob(db::Store& store, const std::string& sha,
                const fs::path& path) {
  fs::create_directories(path.parent_path());
  std::ofstream out(path, std::ios::binary);
  store.read_blob(sha, out);
  if (!out) throw std::runtime_error("cannot write " + path.string());
}

// The model's clouds: the sparse PLY's blob and the dense cloud's tiles,
// and with --models both written as DIR/{site}/sparse.ply and dense.ply.
void print_clouds(db::Store& store, const SummaryArgs& a,
                  const std::string& site, const db::Document& model) {
  const fs::path dir = fs::path(a.models) / site;
  if (model.blobs.count("sparse")) {
    const std::string sha = model.blobs.at("sparse");
    std::cout << "  sparse: /v1/blobs/" << sha;
    if (!a.models.empty()) {
      write_blob(store, sha, dir / "sparse.ply");
      std::cout << " -> " << (dir / "sparse.ply").string();
    }
    std::cout << "\n";
  }
  const std::vector<std::string> tiles = engine::dense_cloud_blobs(model);
  if (tiles.empty()) return;
  std::cout << "  dense: " << tiles.size() << " tile"
            << (tiles.size() == 1 ? "" : "s") << " (/v1/blobs/{sha} each)";
  if (!a.models.empty()) {
    fs::create_directories(dir);
    engine::write_ply((dir / "dense.ply").string(),
                      engine::load_dense_cloud(store, tiles),
                      "arscout site " + site + " dense cloud");
    std::cout << " -> " << (dir / "dense.ply").string();
  }
  std::cout << "\n";
}

// The model's textured mesh (docs/mesh.md): its tiles with a surface and
// their triangles at the finest level.
void print_mesh(const db::Document& model) {
  std::size_t tiles = 0, triangles = 0;
  for (const engine::MeshTileEntry& tile : engine::mesh_tiles_of(model)) {
    if (tile.levels.empty()) continue;  // its points made no surface
    ++tiles;
    triangles += tile.levels.front().triangles;
  }
  if (tiles == 0) return;
  std::cout << "  mesh: " << tiles << " tile" << (tiles == 1 ? "" : "s") << ", "
            << triangles
            << " triangles at the finest level (GET /v1/sites/{id}/mesh)\n";
}

// A site's captures by status and its model's version and counts.
void print_site(db::Store& store, const SummaryArgs& a,
                const db::Document& site_doc) {
  const std::string id(db::leaf_name(site_doc.path));
  const documents::Site site = documents::site_from_json(site_doc.attrs, id);
  std::cout << "\nsite " << id;
  if (site.name != id)
    std::cout << " (" << site.name << ")";  // once, not twice
  if (site.centre)
    std::cout << std::fixed << std::setprecision(6) << ", centre "
              << site.centre->lat << ", " << site.centre->lon
              << std::defaultfloat;
  std::cout << "\n  captures " << site.captures.size() << ":";
  for (const auto& [status, n] : capture_statuses(store, site.captures))
    std::cout << " " << n << " " << status;
  std::cout << "\n";
  auto model = store.get(site_doc.path + "/model");
  if (!model) {
    std::cout << "  no model yet (a site needs 3 captures)\n";
    return;
  }
  const documents::ModelDocument m = documents::model_from_json(model->attrs);
  std::cout << "  model version " << model->version << ": "
            << m.statistics.registered << " registered, "
            << m.statistics.sparse_points << " sparse points, "
            << m.statistics.dense_points << " dense points, frame "
            << (m.geo_registered ? "enu" : "local") << "\n";
  print_clouds(store, a, id, *model);
  print_mesh(*model);
}

int run_summary(const SummaryArgs& a) {
  auto store = db::Store::open(a.db);
  if (a.wait_s > 0 && !wait_for_engine(*store, a)) {
    std::cerr << "arscout summary: engine '" << a.engine
              << "' has not caught up after " << a.wait_s << " s\n";
    return kExitError;
  }
  const auto sites = store->list_children("/sites");
  std::cout << sites.size() << " site" << (sites.size() == 1 ? "" : "s")
            << " in " << a.db << "\n";
  for (const db::Document& site : sites) print_site(*store, a, site);
  std::cout << std::flush;
  return kExitOk;
}

void add_summary_command(CLI::App& app) {
  static SummaryArgs args;
  CLI::App* cmd = app.add_subcommand(
      "summary",
      "list the sites, their captures' status and model versions; with "
      "--models DIR write each site's point clouds as PLY files");
  cmd->add_option("--db", args.db,
                  "database URL: sqlite:FILE or postgresql://...")
      ->required();
  cmd->add_option("--models", args.models,
                  "write DIR/SITE/sparse.ply and DIR/SITE/dense.ply");
  cmd->add_option("--wait", args.wait_s,
                  "first wait up to this many seconds for the engine to "
                  "catch up with every capture and finish the dense clouds")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--engine-name", args.engine,
                  "the engine whose checkpoint --wait watches")
      ->capture_default_str();
  cmd->callback([] { run_command([] { return run_summary(args); }); });
}

const CommandRegistration summary_command_registration(26, add_summary_command);

}  // namespace
}  // namespace arscout::cli
