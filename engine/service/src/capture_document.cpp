#include "capture_document.h"

#include <stdexcept>

#include "arscout/db/store.h"
#include "arscout/documents/capture.h"
#include "arscout/documents/document_error.h"

namespace arscout::engine::service {

std::optional<GeoFix> geo_fix(const std::optional<documents::GpsFix>& gps) {
  if (!gps) return std::nullopt;
  return geo_fix_of(*gps);
}

std::optional<CameraIntrinsics> camera_intrinsics(const nlohmann::json& attrs) {
  try {
    CameraIntrinsics k = documents::camera_from_json(attrs);
    if (!validate(k).empty()) return std::nullopt;
    return k;
  } catch (const documents::DocumentError&) {
    return std::nullopt;
  }
}

namespace {

db::Document capture_document(db::Store& store, const std::string& capture) {
  auto doc = store.get("/captures/" + capture);
  if (!doc) throw std::invalid_argument("capture " + capture + " is gone");
  return std::move(*doc);
}

std::string image_sha(const db::Document& doc, const std::string& capture) {
  if (!doc.blobs.count("image"))
    throw std::runtime_error("capture " + capture + " has no image");
  return doc.blobs.at("image");
}

CaptureInput input_of(db::Store& store, const db::Document& doc,
                      const std::string& capture, std::string image_bytes) {
  CaptureInput input;
  input.id = capture;
  input.image_bytes = std::move(image_bytes);
  const documents::Capture attrs = documents::capture_from_json(doc.attrs);
  input.gps = geo_fix(attrs.gps);
  input.scout = attrs.scout;
  if (!attrs.camera.empty()) {
    input.camera_id = attrs.camera;
    if (auto cam = store.get("/cameras/" + attrs.camera))
      input.camera = camera_intrinsics(cam->attrs);
  } else {
    input.camera_id = "unnamed-" + std::to_string(attrs.width) + "x" +
                      std::to_string(attrs.height);
  }
  return input;
}

}  // namespace

std::string capture_image_sha(db::Store& store, const std::string& capture) {
  return image_sha(capture_document(store, capture), capture);
}

CaptureInput capture_input(db::Store& store, const std::string& capture,
                           std::string image_bytes) {
  return input_of(store, capture_document(store, capture), capture,
                  std::move(image_bytes));
}

CaptureInput stored_capture_input(db::Store& store,
                                  const std::string& capture) {
  const db::Document doc = capture_document(store, capture);
  return input_of(store, doc, capture, store.get_blob(image_sha(doc, capture)));
}

}  // namespace arscout::engine::service
