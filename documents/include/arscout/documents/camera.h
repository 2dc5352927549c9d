// The camera form: the attributes of /cameras/{id} (docs/api.md) and of
// each entry of a model document's "cameras". A pinhole with
// radial-tangential distortion in OpenCV's order, in pixels of the original
// photo, pixel centres at integer coordinates (OpenCV's convention).
#pragma once

#include <string>

#include <nlohmann/json_fwd.hpp>

namespace arscout::documents {

struct Camera {
  int width = 0;  // of the original photo, pixels
  int height = 0;
  double fx = 0;
  double fy = 0;
  double cx = 0;
  double cy = 0;
  // Brown-Conrady coefficients in OpenCV's order.
  double k1 = 0;
  double k2 = 0;
  double p1 = 0;
  double p2 = 0;
  double k3 = 0;
  // "calibrated", "exif" or "estimated": how far to trust the numbers.
  std::string source = "calibrated";
  // Of a chessboard fit (ingest/calibration.h); images_used 0 when the
  // camera did not come from one, and then neither is stored.
  double rms_px = 0;
  int images_used = 0;

  bool has_distortion() const {
    return k1 != 0 || k2 != 0 || p1 != 0 || p2 != 0 || k3 != 0;
  }
};

// The distortion rule, the same for every reader: "distortion" is absent,
// null, or an array of 0 to 8 finite numbers in OpenCV's order [k1, k2,
// p1, p2, k3, k4, k5, k6]. Missing terms are zero. Terms past the fifth
// (OpenCV's rational model) must be zero: the engine's model has five, and
// dropping a non-zero term would bend every ray, so such a camera is
// refused rather than read wrongly. Writers always write the five terms.

// {"fx", "fy", "cx", "cy", "width", "height", "distortion": [k1, k2, p1,
// p2, k3], "source"}, plus "rms_px" and "images_used" when images_used > 0.
nlohmann::json to_json(const Camera& camera);

// "" when `attrs` is a valid camera, else a message that names the first
// bad field. Required: fx, fy (positive finite), width, height (positive
// whole numbers), cx, cy (0 <= cx <= width, 0 <= cy <= height), source
// (calibrated, exif or estimated). Optional: distortion (the rule above),
// rms_px (finite, >= 0), images_used (a whole number >= 0). Other fields
// are allowed and ignored.
std::string validate_camera(const nlohmann::json& camera);

// The camera `attrs` states. Throws DocumentError with validate_camera's
// message when it is not valid.
Camera camera_from_json(const nlohmann::json& attrs);

}  // namespace arscout::documents
