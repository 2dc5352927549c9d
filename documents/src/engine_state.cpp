#include "arscout/documents/engine_state.h"

#include <nlohmann/json.hpp>

#include "arscout/documents/capture_status.h"
#include "arscout/documents/document_error.h"
#include "json_fields.h"

namespace arscout::documents {
namespace {

using fields::Json;

std::map<std::string, std::string> statuses_of(const Json& attrs) {
  std::map<std::string, std::string> statuses;
  const Json* object = fields::find(attrs, "statuses");
  if (!object) return statuses;
  if (!object->is_object())
    throw DocumentError("engine state: statuses must be an object");
  for (const auto& [capture, status] : object->items()) {
    if (!status.is_string())
      throw DocumentError("engine state: the status of " + capture +
                          " must be a string");
    statuses[capture] = status.get<std::string>();
  }
  return statuses;
}

// Exactly: feed positions are 64-bit, past a double's whole numbers.
std::int64_t whole_number(const Json& attrs, const char* key) {
  const Json* value = fields::find(attrs, key);
  if (!value) return 0;
  if (value->is_number_integer()) return value->get<std::int64_t>();
  return static_cast<std::int64_t>(fields::number(attrs, key).value_or(0));
}

}  // namespace

Json to_json(const EngineState& state) {
  return Json{{"statuses", state.statuses},
              {kRegisteredCount, state.registered},
              {"through_seq", state.through_seq},
              {"dense_due", state.dense_due}};
}

Json dense_due_patch(bool dense_due) { return Json{{"dense_due", dense_due}}; }

EngineState engine_state_from_json(const Json& attrs) {
  if (!attrs.is_object())
    throw DocumentError("engine state: the attributes must be an object");
  EngineState state;
  state.statuses = statuses_of(attrs);
  state.registered = whole_number(attrs, kRegisteredCount);
  state.through_seq = whole_number(attrs, "through_seq");
  const Json* due = fields::find(attrs, "dense_due");
  state.dense_due = due && due->is_boolean() && due->get<bool>();
  return state;
}

}  // namespace arscout::documents
