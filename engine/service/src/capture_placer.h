// Places the captures the feed brings in sites: the work a capture change
// asks for and its site. A new capture goes by its fix or its site hint
// (SiteDirectory::place); one with neither follows its scout's photos
// taken within kScoutTrailWindowS of it (scout_trails.h), or waits, marked
// "waiting for a position", until one of them is placed. A withdrawn
// capture is withdrawn from its site; one an earlier run committed while
// the site's state stayed unsaved is added again. Used on the feed
// subscription's thread only.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "arscout/db/document.h"
#include "arscout/documents/capture.h"
#include "scout_trails.h"
#include "site_leases.h"
#include "worker_board.h"

namespace arscout::engine::service {

// A photo without a fix or hint goes where its scout's photos taken within
// this many seconds of it went: a few minutes' walk.
constexpr std::int64_t kScoutTrailWindowS = 600;

class CapturePlacer {
 public:
  CapturePlacer(WorkerBoard& board, SiteLeases& leases)
      : board_(board), leases_(leases) {}

  // The work `change` asks for, each with its site: none for changes that
  // need none (the engine's own status updates among them); with a new
  // capture, the merges of the sites its fix meets as well. Reads (and may
  // write) the store without the board's lock; throws what it throws.
  std::vector<std::pair<std::string, Work>> place(const db::Change& change);

 private:
  std::vector<std::pair<std::string, Work>> place_new(
      const db::Change& change, const std::string& id,
      const documents::Capture& capture);
  std::vector<std::pair<std::string, Work>> wait_for_position(
      const db::Change& change, const std::string& id,
      const documents::Capture& capture, std::int64_t taken);
  std::vector<std::pair<std::string, Work>> unsaved_work(
      const db::Change& change, const std::string& id,
      const documents::Capture& capture);

  WorkerBoard& board_;
  SiteLeases& leases_;
  ScoutTrails trails_{kScoutTrailWindowS};
};

// A new site's name until someone renames it: its founding scout and when
// the photo was taken, "alice 2026-12-06 14:05" (UTC).
std::string default_site_name(const documents::Capture& capture,
                              std::int64_t taken);

}  // namespace arscout::engine::service
