// Recorded scouting sessions (docs/sessions.md): a store's change log
// written to a file with the documents and blobs of the scouts' inputs, and
// replayed into another store through the API's own handlers, so the
// engine sees the same captures arrive in the same order and rhythm.
//
// A session file is JSON Lines:
//
//   {"type":"session","format":"arscout-session","version":1,"since":N,
//    "last_seq":M,"backend":"sqlite","exported":"2026-..."}
//   {"type":"blob","sha256":H,"size":B,"base64":"..."}   before its first use
//   {"type":"change","seq":S,"time_us":T,"path":P,"op":"put|patch|delete",
//    "version":V,"kind":K,"author":A,"input":"capture|withdrawal|camera",
//    "attrs":{...},"blobs":{...}}                        every change
//   {"type":"end","changes":C,"blobs":B}
//
// Every change of the log is listed; "input", "attrs" and "blobs" only on
// the scouts' inputs: a capture's upload, its withdrawal, a camera. What
// the engine derives (sites, models, statuses) is recomputed on replay, not
// copied. The store keeps no history, so an input's content is its
// document's content at export time with the engine's fields removed
// (site, status, status_reason): what the scout sent.
#pragma once

#include <cstdint>
#include <functional>
#include <iosfwd>
#include <string>

#include "arscout/db/store.h"

namespace arscout::ingest {

struct SessionSummary {
  std::int64_t changes = 0;  // change lines
  std::int64_t inputs = 0;   // of which scouts' inputs
  std::int64_t blobs = 0;
  std::int64_t blob_bytes = 0;
  std::int64_t first_seq = 0;
  std::int64_t last_seq = 0;
};

// Writes the changes after `since`. `progress` (may be empty) is called
// after each change with the summary so far. Throws db::StoreError.
SessionSummary export_session(
    db::Store& store, std::int64_t since, std::ostream& out,
    const std::function<void(const SessionSummary&)>& progress = {});

struct ReplayOptions {
  // Inter-arrival times are divided by `speed`; `fast` applies the inputs
  // back to back.
  double speed = 1;
  bool fast = false;
  // Called after each input with its path and HTTP status.
  std::function<void(const std::string& path, int status)> progress;
  // Replaying stops early (returns) once this says true.
  std::function<bool()> stop;
};

struct ReplaySummary {
  int captures = 0;  // uploads stored (201) or already there (replays)
  int withdrawals = 0;
  int cameras = 0;
  int failed = 0;  // inputs the API refused
  std::int64_t changes_read = 0;
  double seconds = 0;
};

// Reads the session file at `path` and applies its inputs to `store`
// through the v1 API's handlers, as their scouts (a capture keeps its id,
// so replaying twice stores nothing new). The whole file is checked first:
// a malformed or truncated file throws std::runtime_error("PATH:LINE:
// what") and nothing is applied.
ReplaySummary replay_session(const std::string& path, db::Store& store,
                             const ReplayOptions& options);

}  // namespace arscout::ingest
