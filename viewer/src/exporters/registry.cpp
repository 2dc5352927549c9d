// The export formats: one line each, naming the Exporter its file defines
// (docs/ARCHITECTURE.md, "Adding an export format"). The order is the order
// the CLI's --help, GET /v1/exports and the viewer list them in.
#include <algorithm>

#include "arscout/viewer/exporter.h"

#define ARSCOUT_EXPORT_FORMATS(FORMAT) \
  FORMAT(ply)                          \
  FORMAT(colmap)                       \
  FORMAT(geocsv)                       \
  FORMAT(ecef_ply)                     \
  FORMAT(las)                          \
  FORMAT(tiles3d)                      \
  FORMAT(geojson)                      \
  FORMAT(glb)                          \
  FORMAT(obj)                          \
  FORMAT(tiles3d_mesh)

namespace arscout::viewer {
namespace formats {

#define ARSCOUT_DECLARE_EXPORTER(variable) extern const Exporter variable;
ARSCOUT_EXPORT_FORMATS(ARSCOUT_DECLARE_EXPORTER)
#undef ARSCOUT_DECLARE_EXPORTER

}  // namespace formats

const std::vector<const Exporter*>& exporters() {
#define ARSCOUT_LIST_EXPORTER(variable) &formats::variable,
  static const std::vector<const Exporter*> all = {
      ARSCOUT_EXPORT_FORMATS(ARSCOUT_LIST_EXPORTER)};
#undef ARSCOUT_LIST_EXPORTER
  return all;
}

const Exporter* find_exporter(std::string_view name) {
  const auto& all = exporters();
  const auto it = std::find_if(all.begin(), all.end(), [&](const Exporter* e) {
    return e->name == name;
  });
  return it == all.end() ? nullptr : *it;
}

std::string exporter_names(std::string_view separator) {
  std::string names;
  for (const Exporter* e : exporters()) {
    if (!names.empty()) names += separator;
    names += e->name;
  }
  return names;
}

}  // namespace arscout::viewer
