// The capture form: the attributes of /captures/{id} (docs/api.md). The API
// writes a capture when a photo is uploaded; the engine and the API then
// change only its status (status_patch).
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include <nlohmann/json_fwd.hpp>

#include "arscout/documents/capture_status.h"
#include "arscout/documents/gps.h"

namespace arscout::documents {

// What the photo's EXIF said, as far as the engine may use it.
struct CaptureExif {
  std::optional<double> focal_35mm;
  std::optional<double> focal_mm;
  std::string make;
  std::string model;
};

struct Capture {
  std::string scout;     // the uploading token's name
  std::string received;  // RFC 3339 UTC
  std::string format;    // "jpeg", "png", ...
  int width = 0;         // pixels, from the image's own header
  int height = 0;
  std::uint64_t bytes = 0;
  // None when the document holds no status or a word this version does
  // not know (capture_status.h has the words and who writes which).
  std::optional<CaptureStatus> status;
  std::string status_reason;
  std::string taken;  // RFC 3339, or "" when unknown
  std::optional<GpsFix> gps;
  std::string camera;     // a /cameras/{id} id, or ""
  std::string site_hint;  // or ""
  std::string filename;   // or ""
  CaptureExif exif;
  std::string site;  // set by the engine once placed, else ""
  // The component of the site's model it registered in (docs/engine.md,
  // "Components"), set by the engine with the status registered.
  std::optional<int> component;
};

// The stored attributes: every field above, except that camera, site_hint,
// filename, site, gps and the EXIF fields are left out when empty (and
// status is "" when none).
nlohmann::json to_json(const Capture& capture);

// Reads what a capture document holds. Lenient, as readers of documents
// written by other versions must be: a missing or mistyped field reads as
// its default, a gps that is not a valid fix (gps_from_json) and a status
// that is no capture status's word as none.
// Throws DocumentError only when `attrs` is not a JSON object.
Capture capture_from_json(const nlohmann::json& attrs);

// The merge patch that sets a capture's status (and, when `site` is given,
// the site it was placed in). `component` is written when registered and
// removed otherwise.
nlohmann::json status_patch(CaptureStatus status, const std::string& reason,
                            const std::string& site = "",
                            std::optional<int> component = std::nullopt);

}  // namespace arscout::documents
