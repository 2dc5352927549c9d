// Two `arscout engine` workers on one PostgreSQL database, each a process
// of its own: they split the two sites of the two-scout session between
// them (one site each, through their leases) and reconstruct them at the
// same time; the worker holding lund is then killed with SIGKILL mid-site,
// and the other takes lund over once the lease expires and finishes it.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iostream>
#include <set>
#include <sstream>
#include <thread>

#include "arscout/db/store.h"
#include "arscout/engine/camera.h"
#include "arscout/metadata/gps.h"
#include "camera_document.h"
#include "test_stores.h"
#include "tool_process.h"

namespace arscout {
namespace {

namespace fs = std::filesystem;
using db::Json;
using namespace std::chrono_literals;

std::string read_file(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream bytes;
  bytes << in.rdbuf();
  return bytes.str();
}

std::vector<fs::path> photos(const std::string& dir) {
  std::vector<fs::path> out;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ".jpg") out.push_back(e.path());
  std::sort(out.begin(), out.end());
  return out;
}

void upload(db::Store& store, const std::string& scout, const fs::path& photo,
            const metadata::GpsFix& fix, const std::string& camera) {
  Json attrs = {
      {"scout", scout}, {"gps", metadata::to_json(fix)}, {"status", "stored"}};
  if (!camera.empty()) attrs["camera"] = camera;
  db::WriteOp op = db::WriteOp::put(
      "/captures/" + scout + "-" + photo.stem().string(), "capture", attrs, 0);
  op.blobs = db::BlobRefs{{"image", store.put_blob(read_file(photo))}};
  store.batch({op});
}

// The site a scout's first capture went to, once the engine placed it.
std::string site_of(db::Store& store, const std::string& scout) {
  for (const db::Document& site : store.list_children("/sites"))
    for (const Json& c : site.attrs.value("captures", Json::array()))
      if (c.get<std::string>().rfind(scout + "-", 0) == 0)
        return site.path.substr(7);
  return "";
}

std::string holder_of(db::Store& store, const std::string& site) {
  for (const db::Lease& l : store.leases("site/" + site))
    if (l.name == "site/" + site) return l.holder;
  return "";
}

// Who wrote each version of a site's model, in commit order.
std::vector<std::string> model_authors(db::Store& store,
                                       const std::string& site) {
  std::vector<std::string> out;
  for (const db::Change& c : store.changes(0, "/sites/" + site + "/model"))
    out.push_back(c.author);
  return out;
}

template <typename Pred>
bool wait_until(Pred pred, std::chrono::seconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    if (pred()) return true;
    std::this_thread::sleep_for(250ms);
  }
  return pred();
}

TEST(EngineTakeover, TwoWorkersSplitTheSitesAndOneFinishesTheOthers) {
  std::string fountain, lund, url;
  ARSCOUT_SHARED_DATA_OR_SKIP(fountain, "strecha/fountain-P11");
  ARSCOUT_SHARED_DATA_OR_SKIP(lund, "opensfm/lund");
  ARSCOUT_FRESH_STORE_OR_SKIP(url, "postgresql");
  auto store = db::Store::open(url);
  const engine::CameraIntrinsics K =
      engine::read_k_matrix(fountain + "/images/K.txt", 3072, 2048);
  testing::put_calibrated_camera(*store, "fountain", K);

  const std::string work = testing::make_temp_dir("engine_takeover");
  std::map<std::string, std::unique_ptr<testing::ToolProcess>> workers;
  for (const std::string name : {"engine-a", "engine-b"})
    workers[name] = std::make_unique<testing::ToolProcess>(
        ARSCOUT_CLI,
        std::vector<std::string>{"--log-level", "info", "engine", "--db", url,
                                 "--engine-name", name, "--lease-ttl", "3",
                                 "--site-threads", "1"},
        work + "/" + name + ".log");
  auto logs = [&] {
    return "engine-a:\n" + testing::slurp(work + "/engine-a.log") +
           "engine-b:\n" + testing::slurp(work + "/engine-b.log");
  };
  // Both workers alive (their worker leases taken) before the scouts begin.
  ASSERT_TRUE(
      wait_until([&] { return store->leases("worker/").size() == 2; }, 60s))
      << logs();

  // Two scouts walking: alice one photo a second, bob one every two.
  const auto fixes = metadata::read_gps_csv(fountain + "/gps.csv");
  // jthreads: a store read that throws below fails the test, where a
  // joinable std::thread would abort the process without a word (it did,
  // once, under load).
  std::jthread alice([&] {
    for (const fs::path& p : photos(fountain + "/images")) {
      upload(*store, "alice", p, fixes.at(p.filename().string()), "fountain");
      std::this_thread::sleep_for(1s);
    }
  });
  std::jthread bob([&] {
    for (const fs::path& p : photos(lund + "/images")) {
      upload(*store, "bob", p, *metadata::read_exif_file(p.string()).gps, "");
      std::this_thread::sleep_for(2s);
    }
  });

  // The sites are split: each worker holds one and writes its models.
  std::string fountain_site, lund_site;
  const bool split = wait_until(
      [&] {
        fountain_site = site_of(*store, "alice");
        lund_site = site_of(*store, "bob");
        return !fountain_site.empty() && !lund_site.empty() &&
               model_authors(*store, fountain_site).size() >= 1 &&
               model_authors(*store, lund_site).size() >= 1;
      },
      300s);
  if (!split) {
    alice.join();
    bob.join();
    FAIL() << "no models for both sites\n" << logs();
  }
  const std::string fountain_worker = model_authors(*store, fountain_site)[0];
  const std::string lund_worker = model_authors(*store, lund_site)[0];
  EXPECT_NE(fountain_worker, lund_worker) << "one worker took both sites\n"
                                          << logs();
  EXPECT_EQ(holder_of(*store, lund_site), lund_worker);

  // Kill lund's worker mid-site: more lund photos are still to come.
  const std::int64_t lund_generation =
      store->leases("site/" + lund_site).at(0).generation;
  const std::int64_t through_at_kill =
      store->get("/sites/" + lund_site + "/engine")
          ->attrs.value("through_seq", std::int64_t{0});
  std::cout << "killing " << lund_worker << " after lund model v"
            << model_authors(*store, lund_site).size() << std::endl;
  workers.at(lund_worker)->kill_now();
  const std::string survivor =
      lund_worker == "engine-a" ? "engine-b" : "engine-a";
  alice.join();
  bob.join();
  const std::int64_t last = store->last_change("/captures/*");
  ASSERT_LT(through_at_kill, last) << "lund was finished before the kill";
  const bool finished = wait_until(
      [&] { return store->load_checkpoint(survivor) >= last; }, 600s);
  const std::string survivor_log =
      testing::slurp(work + "/" + survivor + ".log");
  workers.at(survivor)->signal(SIGTERM);
  workers.at(survivor)->wait_for(60s);
  ASSERT_TRUE(finished) << logs();

  // The survivor took the lease over and finished lund.
  const auto lease = store->leases("site/" + lund_site).at(0);
  EXPECT_GT(lease.generation, lund_generation);
  EXPECT_NE(survivor_log.find("site " + lund_site + ": lease taken"),
            std::string::npos)
      << survivor_log;
  const auto authors = model_authors(*store, lund_site);
  EXPECT_EQ(authors.front(), lund_worker);
  EXPECT_EQ(authors.back(), survivor);
  std::cout << "lund model versions by author:";
  for (const std::string& a : authors) std::cout << " " << a;
  std::cout << std::endl;

  ASSERT_EQ(store->list_children("/sites").size(), 2u);
  const auto model = store->get("/sites/" + lund_site + "/model");
  ASSERT_TRUE(model);
  EXPECT_GE(model->attrs.at("statistics").value("registered", 0), 25);
  EXPECT_EQ(store->get("/sites/" + fountain_site + "/model")
                ->attrs.at("statistics")
                .value("registered", 0),
            11);
  // Every capture processed, by one worker or the other (a lund photo
  // that did not register yet stays "stored", waiting for neighbours).
  for (const db::Document& c : store->list_children("/captures")) {
    EXPECT_FALSE(c.attrs.value("site", "").empty()) << c.path;
    if (c.path.rfind("/captures/alice-", 0) == 0) {
      EXPECT_EQ(c.attrs.value("status", ""), "registered") << c.path;
    }
  }
}

}  // namespace
}  // namespace arscout
