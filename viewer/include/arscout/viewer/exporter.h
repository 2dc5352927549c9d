// The export formats, one registry: each format is an Exporter, defined in
// one file of viewer/src/exporters/ and named by one line of its
// registry.cpp (docs/ARCHITECTURE.md, "Adding an export format"). The
// CLI's `export --format` and its --help, GET /v1/exports, the API's
// ?format= and the web viewer's export buttons all come from exporters().
#pragma once

#include <ostream>
#include <string>
#include <string_view>
#include <vector>

#include "arscout/db/store.h"
#include "arscout/viewer/site_model.h"

namespace arscout::viewer {

struct ExportOptions {
  // For formats that take a cloud: the dense one (when the model has one)
  // or the sparse one.
  Cloud cloud = Cloud::kDense;
  // For formats that take a CRS: "utm" (the site's zone) or "EPSG:N", and
  // the heights, "ellipsoid" or "egm96" (docs/frames.md).
  std::string crs = "utm";
  std::string heights = "ellipsoid";
};

struct ExportRequest {
  db::Store& store;
  std::string site;
  ExportOptions options;
};

struct Exporter {
  std::string_view name;       // --format NAME, ?format=NAME
  std::string_view extension;  // of the file, with its dot: ".ply"
  std::string_view mime_type;  // the HTTP Content-Type
  std::string_view summary;    // what the file holds, one line
  bool takes_cloud = false;    // reads ExportOptions::cloud
  bool takes_crs = false;      // reads ExportOptions::crs and heights
  // Writes the site's current model in this format to `out` and returns
  // the file's name, SITE-vVERSION-...EXTENSION: the same model version
  // always gives the same bytes. Throws util::Error kNotFound without a
  // model (or without the cloud it needs) and kInvalidArgument for a model
  // the format cannot describe honestly (a geographic format on a model
  // that is not geo-registered) or options that do not fit the site, the
  // message saying why; what the store throws.
  std::string (*write)(const ExportRequest& request, std::ostream& out);
};

// Every format, in the order the CLI and the viewer list them.
const std::vector<const Exporter*>& exporters();
// The format named `name`, or null.
const Exporter* find_exporter(std::string_view name);
// The formats' names joined by `separator` ("ply | colmap | ..."), for
// help texts and error messages.
std::string exporter_names(std::string_view separator);

}  // namespace arscout::viewer
