#include "change_feed.h"

#include <algorithm>
#include <exception>

#include <spdlog/spdlog.h>

#include "api_handlers.h"

namespace arscout::ingest {

http::EventFeed::Batch ChangeFeed::next() {
  constexpr std::size_t kBatch = 500;
  Batch b;
  std::int64_t last = last_;
  try {
    const std::int64_t head = store_.last_seq();
    const auto changes = store_.changes(last_, where_.pattern, kBatch);
    b.full = changes.size() == kBatch;
    for (const db::Change& c : changes) {
      last = c.seq;
      if (can_read(where_.who, c.path))  // as the documents themselves
        b.texts.push_back(to_json(c).dump());
    }
    // Nothing new is past the head read before the changes, nor past the
    // last change read (written since).
    b.wait_after = std::max(head, last);
  } catch (const std::exception& e) {
    spdlog::warn("event=stream_read_failed since={} error=\"{}\"", last_,
                 e.what());
    b.texts.clear();
    b.full = false;
    b.failed = true;
    return b;
  }
  last_ = last;
  return b;
}

bool ChangeFeed::still_allowed() {
  try {
    return authenticate(store_, where_.authorization).has_value();
  } catch (const std::exception&) {
    return true;  // a store that cannot answer revokes nothing
  }
}

}  // namespace arscout::ingest
