#include "arscout/documents/capture.h"

#include <nlohmann/json.hpp>

#include "arscout/documents/document_error.h"
#include "json_fields.h"

namespace arscout::documents {
namespace {

using fields::Json;
using fields::string_or;

void put_if_set(Json& j, const char* key, const std::string& value) {
  if (!value.empty()) j[key] = value;
}

Json exif_json(const CaptureExif& exif) {
  Json j = Json::object();
  if (exif.focal_35mm) j["focal_35mm"] = *exif.focal_35mm;
  if (exif.focal_mm) j["focal_mm"] = *exif.focal_mm;
  put_if_set(j, "make", exif.make);
  put_if_set(j, "model", exif.model);
  return j;
}

CaptureExif exif_from_json(const Json& attrs) {
  CaptureExif exif;
  const Json* j = fields::find(attrs, "exif");
  if (!j) return exif;
  exif.focal_35mm = fields::number(*j, "focal_35mm");
  exif.focal_mm = fields::number(*j, "focal_mm");
  exif.make = string_or(*j, "make");
  exif.model = string_or(*j, "model");
  return exif;
}

template <typename Number>
Number whole_or_zero(const Json& attrs, const char* key) {
  const Json* j = fields::find(attrs, key);
  return j && j->is_number_integer() && j->get<std::int64_t>() >= 0
             ? j->get<Number>()
             : Number{0};
}

}  // namespace

Json to_json(const Capture& c) {
  Json j{{"scout", c.scout},
         {"received", c.received},
         {"format", c.format},
         {"width", c.width},
         {"height", c.height},
         {"bytes", c.bytes},
         {"status", c.status ? to_string(*c.status) : ""},
         {"status_reason", c.status_reason},
         {"taken", c.taken}};
  if (c.gps) j["gps"] = to_json(*c.gps);
  put_if_set(j, "camera", c.camera);
  put_if_set(j, "site_hint", c.site_hint);
  put_if_set(j, "filename", c.filename);
  put_if_set(j, "site", c.site);
  if (c.component) j["component"] = *c.component;
  if (Json exif = exif_json(c.exif); !exif.empty()) j["exif"] = exif;
  return j;
}

Capture capture_from_json(const Json& attrs) {
  if (!attrs.is_object())
    throw DocumentError("capture: the attributes must be a JSON object");
  Capture c;
  c.scout = string_or(attrs, "scout");
  c.received = string_or(attrs, "received");
  c.format = string_or(attrs, "format");
  c.width = whole_or_zero<int>(attrs, "width");
  c.height = whole_or_zero<int>(attrs, "height");
  c.bytes = whole_or_zero<std::uint64_t>(attrs, "bytes");
  c.status = capture_status_of(string_or(attrs, "status"));
  c.status_reason = string_or(attrs, "status_reason");
  c.taken = string_or(attrs, "taken");
  if (const Json* gps = fields::find(attrs, "gps")) c.gps = gps_from_json(*gps);
  c.camera = string_or(attrs, "camera");
  c.site_hint = string_or(attrs, "site_hint");
  c.filename = string_or(attrs, "filename");
  c.exif = exif_from_json(attrs);
  c.site = string_or(attrs, "site");
  if (const Json* component = fields::find(attrs, "component");
      component && fields::is_whole_number(*component, 0))
    c.component = component->get<int>();
  return c;
}

Json status_patch(CaptureStatus status, const std::string& reason,
                  const std::string& site, std::optional<int> component) {
  Json patch{{"status", to_string(status)}, {"status_reason", reason}};
  if (!site.empty()) patch["site"] = site;
  // null removes it in a merge patch: a withdrawn or dissolved photo has
  // no component.
  patch["component"] = component ? Json(*component) : Json(nullptr);
  return patch;
}

}  // namespace arscout::documents
