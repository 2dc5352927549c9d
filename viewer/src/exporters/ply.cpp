// ply: the cloud as binary PLY in the site's ENU frame (float x y z, uchar
// rgb); the dense cloud when there is one, else the sparse one.
#include "arscout/engine/ply.h"
#include "arscout/util/error.h"
#include "export_support.h"

namespace arscout::viewer::formats {

extern const Exporter ply;

namespace {

std::string write_ply(const ExportRequest& request, std::ostream& out) {
  const SiteModel model = load_site_model(request.store, request.site);
  if (model.sparse_blob.empty())
    throw util::Error(
        util::ErrorKind::kNotFound,
        "site " + request.site + ": the model has no point cloud");
  const Cloud cloud = request.options.cloud;
  // The sparse cloud is one blob; the dense one is joined from its tiles.
  if (std::string_view(cloud_name(model, cloud)) == "sparse")
    put(out, request.store.get_blob(model.sparse_blob));
  else
    put(out, engine::encode_ply(load_cloud(request.store, model, cloud),
                                "arscout site " + request.site + " model v" +
                                    std::to_string(model.version) +
                                    " dense cloud; frame site"));
  return cloud_file_name(model, cloud, ply);
}

}  // namespace

const Exporter ply{"ply",
                   ".ply",
                   "application/x-ply",
                   "the point cloud as binary PLY in the site's ENU frame",
                   true,
                   false,
                   &write_ply};

}  // namespace arscout::viewer::formats
