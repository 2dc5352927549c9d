// The change log as a WebSocket feed (/v1/subscribe, docs/api.md): what
// http::Server's stream session reads, a batch at a time, for one
// subscriber. Knows nothing of sockets.
#pragma once

#include <cstdint>
#include <string>

#include "api.h"
#include "arscout/db/store.h"
#include "arscout/http/server.h"

namespace arscout::ingest {

class ChangeFeed : public http::EventFeed {
 public:
  // The changes after `where.since` that match `where.pattern` and that
  // `where.who` may read, as the documents themselves.
  ChangeFeed(db::Store& store, Api::Subscribe where)
      : store_(store), where_(std::move(where)), last_(where_.since) {}

  // Up to 500 changes of the log, as JSON texts; a store that fails reads
  // nothing (failed), and the next call reads again from the same place:
  // the log is the truth.
  Batch next() override;
  // Whether the token it authenticated with still does (not revoked nor
  // expired). A store that cannot answer revokes nothing.
  bool still_allowed() override;
  std::string stream_key() const override { return where_.authorization; }

 private:
  db::Store& store_;
  const Api::Subscribe where_;
  std::int64_t last_;  // the last seq read
};

}  // namespace arscout::ingest
