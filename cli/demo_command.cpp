// `arscout demo`: the document store alone, end to end on an embedded SQLite
// file: two scouts write captures, a subscriber tails the change feed, a
// planner queries by place, and a stale write is refused. No engine runs:
// the store's contract in a minute, without photos (the whole pipeline is
// `arscout serve --with-engine`, or `arscout engine` beside a server).
#include <iostream>
#include <mutex>
#include <thread>

#include "arscout/db/store.h"
#include "arscout/documents/camera.h"
#include "arscout/documents/capture.h"
#include "arscout/documents/site.h"
#include "cli_support.h"
#include "command_registry.h"
#include "commands.h"

namespace arscout::cli {
namespace {

using db::Json;

struct DemoArgs {
  std::string url = "sqlite:arscout-demo.db";
};

Json capture_attrs(const std::string& scout, double lat, double lon,
                   double h_acc) {
  documents::Capture capture;
  capture.scout = scout;
  capture.camera = "phone-1";
  capture.status = documents::CaptureStatus::kStored;
  capture.gps = documents::GpsFix{lat, lon, 353.0, h_acc, h_acc * 2, 8, "", ""};
  return documents::to_json(capture);
}

// The demo phone's camera as a camera document holds it: the EXIF focal
// length of a 3264 x 2448 photo, no distortion known.
Json phone_camera() {
  documents::Camera camera;
  camera.width = 3264;
  camera.height = 2448;
  camera.fx = camera.fy = 2800;
  camera.cx = 1631.5;
  camera.cy = 1223.5;
  camera.source = "exif";
  return documents::to_json(camera);
}

Json graz_site() {
  documents::Site site;
  site.name = "graz-1";
  site.centre = documents::GeoPoint{47.0707, 15.4395, 353.0};
  site.state = "collecting";
  return documents::to_json(site);
}

int run_demo(const DemoArgs& a) {
  auto store = db::Store::open(a.url);
  std::cout << "store: " << a.url << " (" << store->backend()
            << "), log at seq " << store->last_seq() << "\n";

  std::mutex print_mu;
  auto feed =
      store->subscribe("/**", store->last_seq(), [&](const db::Change& c) {
        std::lock_guard lock(print_mu);
        std::cout << "  feed: seq=" << c.seq << " " << to_string(c.op) << " "
                  << c.path << " v" << c.version << " by " << c.author << "\n";
      });

  store->put("/scouts/alice", "scout",
             Json{{"name", "Alice"}, {"role", "scout"}});
  store->put("/scouts/bob", "scout", Json{{"name", "Bob"}, {"role", "scout"}});
  store->put("/cameras/phone-1", "camera", phone_camera());

  // Two scouts upload concurrently, each photo a blob plus a capture document.
  // Capture ids carry the run, so the demo can run again on the same file.
  const std::string run = std::to_string(store->last_seq());
  auto scout = [&](const std::string& name, double lat0, double lon0) {
    for (int i = 0; i < 4; ++i) {
      std::string image = "demo image of " + name + " #" + std::to_string(i);
      db::WriteOp op = db::WriteOp::put(
          "/captures/" + name + "-" + run + "-" + std::to_string(i), "capture",
          capture_attrs(name, lat0 + i * 2e-5, lon0 + i * 3e-5, 3.5), 0);
      op.blobs = db::BlobRefs{{"image", store->put_blob(image)}};
      op.author = name;
      store->write(op);
    }
  };
  std::thread alice(scout, "alice", 47.0707, 15.4395);  // Graz
  std::thread bob(scout, "bob", 48.2082, 16.3738);      // Vienna
  alice.join();
  bob.join();

  auto site =
      store->batch({db::WriteOp::put("/sites/graz-1", "site", graz_site()),
                    db::WriteOp::patch("/captures/alice-" + run + "-0",
                                       Json{{"site", "graz-1"}})});

  try {  // a planner editing from a stale copy of the site is refused
    store->patch("/sites/graz-1", Json{{"state", "stale"}},
                 site.front().version - 1);
  } catch (const db::ConflictError& e) {
    std::lock_guard lock(print_mu);
    std::cout << "refused as expected: " << e.what() << "\n";
  }

  db::Query near;
  near.pattern = "/captures/*";
  near.near = db::GeoRadius{47.0707, 15.4395, 50.0};
  auto found = store->query(near);
  store->wait_for_change(store->last_seq(), std::chrono::milliseconds(200));
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  feed->stop();

  auto stats = store->stats();
  std::cout << "captures within 50 m of Graz: " << found.size() << "\n"
            << "store now holds " << stats.documents << " documents, "
            << stats.blobs << " blobs (" << stats.blob_bytes
            << " bytes), log at seq " << stats.last_seq << "\n"
            << "try: arscout db ls " << a.url << " '/captures/*'\n"
            << "     arscout db tail " << a.url << "\n";
  return kExitOk;
}

void add_demo_command(CLI::App& app) {
  static DemoArgs args;
  CLI::App* cmd = app.add_subcommand(
      "demo",
      "run the document-store demo (the store alone, no engine): scouts "
      "write captures, a subscriber tails the change feed, a planner queries "
      "by place");
  cmd->add_option("--db", args.url, "database URL")->capture_default_str();
  cmd->callback([] { run_command([] { return run_demo(args); }); });
}

const CommandRegistration demo_command_registration(90, add_demo_command);

}  // namespace
}  // namespace arscout::cli
