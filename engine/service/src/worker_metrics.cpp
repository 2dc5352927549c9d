#include "worker_metrics.h"

#include <sstream>

namespace arscout::engine::service {
namespace {

void write_value(std::ostringstream& out, const char* name, const char* type,
                 const char* help, std::int64_t value) {
  out << "# HELP " << name << " " << help << "\n# TYPE " << name << " " << type
      << "\n"
      << name << " " << value << "\n";
}

}  // namespace

std::string render_metrics(const WorkerStats& s, const PhaseClocks& phases,
                           std::optional<std::int64_t> head) {
  struct Value {
    const char* name;
    const char* type;
    const char* help;
    std::int64_t value;
  };
  const Value values[] = {
      {"arscout_engine_captures_waiting", "gauge",
       "Captures placed and not yet in a committed increment.",
       s.captures_waiting},
      {"arscout_engine_sites", "gauge", "Sites this worker knows.", s.sites},
      {"arscout_engine_sites_held", "gauge", "Site leases this worker holds.",
       s.sites_held},
      {"arscout_engine_site_leases_taken_total", "counter",
       "Site leases claimed.", s.sites_taken},
      {"arscout_engine_sites_merged_total", "counter",
       "Sites merged into another they grew into.", s.sites_merged},
      {"arscout_engine_changes_seen_total", "counter",
       "Capture changes read from the feed.", s.changes_seen},
      {"arscout_engine_captures_placed_total", "counter",
       "Captures placed on a site.", s.captures_placed},
      {"arscout_engine_model_versions_total", "counter",
       "Model versions committed.", s.increments},
      {"arscout_engine_failures_total", "counter",
       "Phases that failed (retried later).", s.failures},
      {"arscout_engine_photos_prepared_total", "counter",
       "Photos decoded and described ahead of their increments.",
       s.photos_prepared},
      {"arscout_engine_photos_prepared_used_total", "counter",
       "Photos prepared ahead that an increment used.", s.photos_prepared_used},
      {"arscout_engine_photos_prepared_late_total", "counter",
       "Photos an increment found still queued and prepared itself.",
       s.photos_prepared_late},
      {"arscout_engine_checkpoint_seq", "gauge",
       "The feed position saved as done.", s.checkpoint},
  };
  std::ostringstream out;
  for (const Value& v : values)
    write_value(out, v.name, v.type, v.help, v.value);
  if (head)
    write_value(out, "arscout_engine_seq_lag", "gauge",
                "Changes committed past the checkpoint.", *head - s.checkpoint);
  out << "# HELP arscout_engine_phase_seconds How long a phase took, from "
         "its start to its writes.\n"
         "# TYPE arscout_engine_phase_seconds histogram\n"
      << phases.sparse.render("arscout_engine_phase_seconds",
                              "phase=\"sparse\"")
      << phases.dense.render("arscout_engine_phase_seconds", "phase=\"dense\"")
      << phases.refine.render("arscout_engine_phase_seconds",
                              "phase=\"refine\"");
  return out.str();
}

}  // namespace arscout::engine::service
