// The engine state header: the attributes of /sites/{id}/engine (type
// "engine-state", docs/service.md), written by the engine service with
// every increment, fenced on its previous version. The reconstruction
// itself is in the document's blobs (state-0000, ...), not here.
#pragma once

#include <cstdint>
#include <map>
#include <string>

#include <nlohmann/json_fwd.hpp>

namespace arscout::documents {

struct EngineState {
  // What was last published per capture, as the engine service keys it
  // (engine/service site_job.cpp: the status's word, then its reason).
  std::map<std::string, std::string> statuses;
  std::int64_t registered = 0;   // images in the sparse model
  std::int64_t through_seq = 0;  // the last feed position folded in
  bool dense_due = false;        // a dense phase is owed (a crash between
                                 // the two phases left it behind)
};

// {"statuses": {capture: status}, registered (the count), "through_seq",
//  "dense_due"}.
nlohmann::json to_json(const EngineState& state);

// The patch a dense phase writes when it ends: {"dense_due": dense_due}.
nlohmann::json dense_due_patch(bool dense_due);

// Reads what an engine state document holds (lenient: a missing field
// reads as its default). Throws DocumentError when `attrs` is not an
// object or "statuses" is not an object of strings: a restart would
// otherwise republish wrong statuses.
EngineState engine_state_from_json(const nlohmann::json& attrs);

}  // namespace arscout::documents
