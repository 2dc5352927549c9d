// The heartbeat thread: renews this worker's site leases every third of
// WorkerOptions::lease_ttl and claims the sites that have deferred work
// (within this worker's share), moving the board's work as sites come and
// go: a gained site's deferred work runs here, a lost site's queued work
// is deferred, and work another worker has committed is settled.
#pragma once

#include <string>

#include "site_leases.h"
#include "site_merger.h"
#include "worker_board.h"

namespace arscout::engine::service {

class LeaseHeartbeat {
 public:
  LeaseHeartbeat(WorkerBoard& board, SiteLeases& leases, SiteMerger& merger)
      : board_(board), leases_(leases), merger_(merger) {}

  // Renews the leases and brings the board in line. Without the lock;
  // throws what the store throws.
  void renew();
  // The heartbeat thread's loop, until the board stops.
  void run();

 private:
  void claim();
  void lose(const std::string& site);  // with the lock

  WorkerBoard& board_;
  SiteLeases& leases_;
  SiteMerger& merger_;
};

}  // namespace arscout::engine::service
