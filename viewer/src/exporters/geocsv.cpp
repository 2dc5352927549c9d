// geocsv: image,latitude,longitude,altitude for each registered camera's
// centre on WGS84 (ellipsoidal height).
#include "arscout/engine/model_io.h"
#include "export_support.h"

namespace arscout::viewer::formats {

extern const Exporter geocsv;

namespace {

std::string write_geocsv(const ExportRequest& request, std::ostream& out) {
  SiteModel model;
  const engine::Model full =
      load_consistent_full_model(request.store, request.site, &model);
  geographic_origin(model);  // refuses a model without geography
  engine::write_geo_csv(full, out);
  return versioned_name(model, "cameras", geocsv.extension);
}

}  // namespace

const Exporter geocsv{"geocsv",
                      ".csv",
                      "text/csv; charset=utf-8",
                      "the registered cameras' positions on WGS84 as CSV",
                      false,
                      false,
                      &write_geocsv};

}  // namespace arscout::viewer::formats
