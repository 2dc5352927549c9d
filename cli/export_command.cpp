// `arscout export`: a site's model in a standard file (docs/frames.md), the
// same bytes as GET /v1/sites/{id}/export.
#include <filesystem>
#include <fstream>
#include <iostream>

#include "arscout/util/error.h"
#include "arscout/viewer/exports.h"
#include "cli_support.h"
#include "command_registry.h"
#include "commands.h"

namespace arscout::cli {
namespace {

namespace fs = std::filesystem;

struct ExportArgs {
  std::string db;
  std::string site;
  std::string format;
  std::string cloud = "dense";
  std::string crs = "utm";
  std::string heights = "ellipsoid";
  std::string output;
};

int run_export(const ExportArgs& a) {
  const viewer::Exporter* format = viewer::find_exporter(a.format);
  if (!format)
    throw util::Error(util::ErrorKind::kInvalidArgument,
                      "--format must be " + viewer::exporter_names(", ") +
                          ", not '" + a.format + "'");
  viewer::ExportOptions options;
  options.cloud =
      a.cloud == "sparse" ? viewer::Cloud::kSparse : viewer::Cloud::kDense;
  options.crs = a.crs;
  options.heights = a.heights;
  auto store = db::Store::open(a.db);
  const viewer::ExportFile file =
      viewer::export_site(*store, a.site, *format, options);
  if (a.output == "-") {
    std::cout.write(file.bytes.data(),
                    static_cast<std::streamsize>(file.bytes.size()));
    return kExitOk;
  }
  write_output_file(a.output, file.bytes);
  std::cerr << "wrote " << file.bytes.size() << " bytes (" << file.filename
            << ") to " << a.output << std::endl;
  return kExitOk;
}

// The formats, a line each, from the registry: the command's help footer.
std::string formats_help() {
  std::string help = "Formats (GET /v1/exports lists the same):";
  for (const viewer::Exporter* e : viewer::exporters())
    help += "\n  " + std::string(e->name) + " (" + std::string(e->extension) +
            "): " + std::string(e->summary);
  return help;
}

// The formats that read an option (Exporter::takes_cloud, takes_crs).
std::string formats_taking(bool viewer::Exporter::*option) {
  std::string names;
  for (const viewer::Exporter* e : viewer::exporters()) {
    if (!(e->*option)) continue;
    if (!names.empty()) names += ", ";
    names += e->name;
  }
  return names;
}

void add_export_command(CLI::App& app) {
  static ExportArgs args;
  CLI::App* cmd = app.add_subcommand(
      "export",
      "write a site's current model in a standard file (docs/frames.md)");
  cmd->footer(formats_help());
  cmd->add_option("--db", args.db,
                  "database URL: sqlite:FILE or postgresql://...")
      ->required();
  cmd->add_option("--site", args.site, "site id, e.g. s-alice-0000")
      ->required();
  cmd->add_option("--format", args.format, viewer::exporter_names(" | "))
      ->required();
  cmd->add_option("--cloud", args.cloud,
                  "for " + formats_taking(&viewer::Exporter::takes_cloud) +
                      ": dense (when the model has one) or sparse")
      ->capture_default_str()
      ->check(CLI::IsMember({"dense", "sparse"}));
  const std::string crs_formats = formats_taking(&viewer::Exporter::takes_crs);
  cmd->add_option("--crs", args.crs,
                  "for " + crs_formats +
                      ": utm (the site's UTM zone) or EPSG:<code> of a "
                      "projected or geographic CRS covering the site")
      ->capture_default_str();
  cmd->add_option("--heights", args.heights,
                  "for " + crs_formats +
                      ": ellipsoid (WGS84) or egm96 (above the EGM96 geoid)")
      ->capture_default_str()
      ->check(CLI::IsMember({"ellipsoid", "egm96"}));
  cmd->add_option("-o,--output", args.output, "file to write ('-': stdout)")
      ->required();
  cmd->callback([] { run_command([] { return run_export(args); }); });
}

const CommandRegistration export_command_registration(54, add_export_command);

}  // namespace
}  // namespace arscout::cli
