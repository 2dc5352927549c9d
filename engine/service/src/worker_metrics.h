// The engine worker's metrics in the Prometheus text format, for
// `arscout engine --listen` and `arscout serve --with-engine`
// (docs/service.md, "Health and metrics").
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "arscout/engine/service.h"
#include "arscout/util/histogram.h"

namespace arscout::engine::service {

// How long each kind of phase took, from start to the writes being ready.
struct PhaseClocks {
  util::Histogram sparse;  // an increment: new captures registered
  util::Histogram dense;   // a dense phase: sweeps and fusion
  util::Histogram refine;  // a global refinement call
};

// `head`: the change log's last seq, for the lag behind it.
std::string render_metrics(const WorkerStats& stats, const PhaseClocks& phases,
                           std::optional<std::int64_t> head);

}  // namespace arscout::engine::service
