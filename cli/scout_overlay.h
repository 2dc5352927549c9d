// `arscout scout`: each uploaded photo's verdict as the engine gives it,
// "NAME  registered · site S · model vN" (the model version that holds
// it) or why not; with --overlay DIR also its AR overlay (the site's model
// drawn over it, GET /v1/captures/{id}/overlay.jpg) saved as
// DIR/{photo stem}.overlay.jpg. A thread of its own polls, so the uploads
// keep their pace.
#pragma once

#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "arscout/http/client.h"

namespace arscout::cli {

class VerdictWatcher {
 public:
  // Gives up on a photo `timeout_s` after add() when it is not registered.
  // `overlay_dir` "": no overlays.
  VerdictWatcher(http::ClientOptions client, std::string overlay_dir,
                 double timeout_s);
  ~VerdictWatcher();  // stops without waiting for the pending photos
  VerdictWatcher(const VerdictWatcher&) = delete;
  VerdictWatcher& operator=(const VerdictWatcher&) = delete;

  void add(const std::string& capture_id, const std::string& file_name);
  // Waits until every photo has its verdict or timed out (or SIGINT);
  // returns how many overlays were saved.
  int finish();

 private:
  struct Pending;
  void run();
  // True when the photo is done with (its verdict said, or given up).
  bool poll(http::Client& client, const Pending& p);
  // Says the photo is registered, with its model version, and saves its
  // overlay when asked to; false when the overlay is not ready yet.
  bool registered(http::Client& client, const Pending& p,
                  const std::string& site);

  http::ClientOptions client_options_;
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
