// geojson: the registered cameras as GeoJSON points (WGS84) with their
// heading and pitch, for web maps: the bytes of GET
// /v1/sites/{id}/cameras.geojson.
#include "arscout/documents/geojson.h"
#include "arscout/documents/document_error.h"
#include "arscout/util/error.h"
#include "export_support.h"

namespace arscout::viewer::formats {

extern const Exporter geojson;

namespace {

std::string write_geojson(const ExportRequest& request, std::ostream& out) {
  const SiteModel model = load_site_model(request.store, request.site);
  geographic_origin(model);  // refuses a model without geography
  try {
    // As HttpResponse::json writes it, so the CLI and GET
    // .../cameras.geojson give the same bytes.
    put(out,
        documents::cameras_geojson(model.document)
            .dump(-1, ' ', false, nlohmann::json::error_handler_t::replace));
  } catch (const documents::DocumentError& e) {
    throw util::Error(util::ErrorKind::kInvalidArgument, e.what());
  }
  return versioned_name(model, "cameras", geojson.extension);
}

}  // namespace

const Exporter geojson{
    "geojson",
    ".geojson",
    "application/geo+json",
    "the registered cameras as GeoJSON points with heading and pitch",
    false,
    false,
    &write_geojson};

}  // namespace arscout::viewer::formats
