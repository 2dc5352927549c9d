// The engine state blob in content-defined parts. One increment changes a
// bounded share of a site's state (the new capture, the cameras and points
// of its local window), yet the whole state, about 70 KB per registered
// photo, was written as one blob at every increment: 14 MB, about 0.25 s
// at 200 photos, on the latency path and growing with the site. Cut where
// the content says (a rolling hash of the last bytes), the parts around an
// edit change and the others keep their bytes, so the store, which keeps a
// blob once per content, writes only the changed ones.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "arscout/db/document.h"

namespace arscout::db {
class Store;
}

namespace arscout::engine::service {

// The most parts a state is cut into (each a blob reference of the engine
// document): parts are at least size / kMaxStateParts bytes (and 64 KiB).
inline constexpr size_t kMaxStateParts = 400;

// Consecutive views of `bytes` that together are `bytes`; none when it is
// empty. A cut follows from the bytes before it alone (within a part-size
// class: the minimum part size doubles as the state does), so an edit
// moves only the cuts next to it.
std::vector<std::string_view> cut_state_parts(std::string_view bytes);

// The blob name of part `index`: "state-0000", "state-0001", ...
std::string state_part_name(size_t index);

// The state bytes an engine document refers to: its parts joined in
// order, or the single blob `state` of documents written before parts;
// nullopt when it refers to neither.
std::optional<std::string> read_state_bytes(db::Store& store,
                                            const db::Document& engine_doc);

}  // namespace arscout::engine::service
