// colmap: the COLMAP text model (cameras.txt, images.txt, points3D.txt in a
// folder SITE/) as a tar; its world frame is the site's ENU.
#include <sstream>

#include "arscout/engine/model_io.h"
#include "export_support.h"
#include "tar_writer.h"

namespace arscout::viewer::formats {

extern const Exporter colmap;

namespace {

std::string write_colmap(const ExportRequest& request, std::ostream& out) {
  SiteModel model;
  const engine::Model full =
      load_consistent_full_model(request.store, request.site, &model);
  // The model's commit time, so the same version always exports the same
  // bytes.
  const long long mtime = model.updated_us / 1000000;
  TarWriter tar;
  for (const engine::ColmapTextFile file :
       {engine::ColmapTextFile::kCameras, engine::ColmapTextFile::kImages,
        engine::ColmapTextFile::kPoints}) {
    std::ostringstream text;
    engine::write_colmap_text(full, file, text);
    tar.add(request.site + "/" + engine::colmap_file_name(file), text.str(),
            mtime);
  }
  put(out, tar.finish());
  return versioned_name(model, "colmap", colmap.extension);
}

}  // namespace

const Exporter colmap{
    "colmap",
    ".tar",
    "application/x-tar",
    "the COLMAP text model (cameras, images, points) in a tar",
    false,
    false,
    &write_colmap};

}  // namespace arscout::viewer::formats
