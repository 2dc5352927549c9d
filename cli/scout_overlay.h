// `arscout scout --overlay DIR`: each uploaded photo's AR overlay (the
// site's model drawn over it, GET /v1/captures/{id}/overlay.jpg) saved as
// DIR/{photo stem}.overlay.jpg once the engine has registered the photo. A
// thread of its own polls, so the uploads keep their pace.
#pragma once

#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "arscout/ingest/client.h"

namespace arscout::cli {

class OverlaySaver {
 public:
  // Gives up on a photo `timeout_s` after add() when it is not registered.
  OverlaySaver(ingest::ClientOptions client, std::string dir, double timeout_s);
  ~OverlaySaver();  // stops without waiting for the pending photos
  OverlaySaver(const OverlaySaver&) = delete;
  OverlaySaver& operator=(const OverlaySaver&) = delete;

  void add(const std::string& capture_id, const std::string& file_name);
  // Waits until every photo is saved, rejected or timed out (or SIGINT);
  // returns how many overlays were saved.
  int finish();

 private:
  struct Pending;
  void run();
  // True when the photo is done with (saved or given up).
  bool poll(ingest::Client& client, const Pending& p);

  ingest::ClientOptions client_options_;
  std::string dir_;
  double timeout_s_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<std::shared_ptr<Pending>> pending_;
  bool stopping_ = false;
  int saved_ = 0;
  std::thread thread_;
};

}  // namespace arscout::cli
