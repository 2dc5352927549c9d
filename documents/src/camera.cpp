#include "arscout/documents/camera.h"

#include <array>

#include "arscout/documents/document_error.h"
#include "json_fields.h"

namespace arscout::documents {
namespace {

using fields::is_finite_number;
using fields::is_whole_number;
using fields::Json;

constexpr std::size_t kModelledTerms = 5;
constexpr std::size_t kMaxDistortionTerms = 8;
constexpr char kSources[] = "calibrated, exif or estimated";

std::string check_positive(const Json& camera, const char* key,
                           const char* what) {
  auto it = camera.find(key);
  if (it == camera.end())
    return std::string(key) + " is missing (" + what + ")";
  if (!is_finite_number(*it) || it->get<double>() <= 0)
    return std::string(key) + " must be a positive finite number (" + what +
           ")";
  return "";
}

std::string check_size(const Json& camera, const char* key) {
  auto it = camera.find(key);
  if (it == camera.end())
    return std::string(key) + " is missing (image size in pixels)";
  if (!is_whole_number(*it, 1))
    return std::string(key) + " must be a positive whole number of pixels";
  return "";
}

std::string check_principal(const Json& camera, const char* key,
                            const char* size_key) {
  auto it = camera.find(key);
  if (it == camera.end())
    return std::string(key) + " is missing (principal point in pixels)";
  const double limit = camera[size_key].get<double>();
  if (!is_finite_number(*it) || it->get<double>() < 0 ||
      it->get<double>() > limit)
    return std::string(key) + " must lie inside the image: 0 <= " + key +
           " <= " + size_key + " (" + std::to_string(static_cast<int>(limit)) +
           ")";
  return "";
}

std::string check_distortion(const Json& camera) {
  const Json* terms = fields::find(camera, "distortion");
  if (!terms) return "";
  if (!terms->is_array() || terms->size() > kMaxDistortionTerms)
    return "distortion must be an array of 0 to 8 finite numbers "
           "[k1, k2, p1, p2, k3, ...]";
  for (std::size_t i = 0; i < terms->size(); ++i) {
    if (!is_finite_number((*terms)[i]))
      return "distortion[" + std::to_string(i) + "] must be a finite number";
    if (i >= kModelledTerms && (*terms)[i].get<double>() != 0)
      return "distortion[" + std::to_string(i) +
             "] must be 0: the camera model has five terms [k1, k2, p1, p2, "
             "k3] (OpenCV's rational terms k4-k6 are not modelled)";
  }
  return "";
}

std::string check_source(const Json& camera) {
  auto it = camera.find("source");
  if (it == camera.end())
    return std::string("source is missing (") + kSources + ")";
  if (!it->is_string() ||
      (*it != "calibrated" && *it != "exif" && *it != "estimated"))
    return std::string("source must be one of ") + kSources;
  return "";
}

std::string check_fit_statistics(const Json& camera) {
  const Json* rms = fields::find(camera, "rms_px");
  if (rms && (!is_finite_number(*rms) || rms->get<double>() < 0))
    return "rms_px must be a finite number >= 0 (pixels)";
  const Json* used = fields::find(camera, "images_used");
  if (used && !is_whole_number(*used, 0))
    return "images_used must be a whole number >= 0";
  return "";
}

}  // namespace

Json to_json(const Camera& c) {
  Json j{{"fx", c.fx},
         {"fy", c.fy},
         {"cx", c.cx},
         {"cy", c.cy},
         {"width", c.width},
         {"height", c.height},
         {"distortion", {c.k1, c.k2, c.p1, c.p2, c.k3}},
         {"source", c.source}};
  if (c.images_used > 0) {
    j["rms_px"] = c.rms_px;
    j["images_used"] = c.images_used;
  }
  return j;
}

std::string validate_camera(const Json& camera) {
  if (!camera.is_object()) return "a camera must be a JSON object";
  // Sizes first: the principal point is checked against them.
  for (const std::string& problem :
       {check_size(camera, "width"), check_size(camera, "height"),
        check_positive(camera, "fx", "focal length in pixels"),
        check_positive(camera, "fy", "focal length in pixels")})
    if (!problem.empty()) return problem;
  for (const std::string& problem :
       {check_principal(camera, "cx", "width"),
        check_principal(camera, "cy", "height"), check_distortion(camera),
        check_source(camera), check_fit_statistics(camera)})
    if (!problem.empty()) return problem;
  return "";
}

Camera camera_from_json(const Json& attrs) {
  if (std::string problem = validate_camera(attrs); !problem.empty())
    throw DocumentError("camera: " + problem);
  Camera c;
  c.width = attrs.at("width").get<int>();
  c.height = attrs.at("height").get<int>();
  c.fx = attrs.at("fx").get<double>();
  c.fy = attrs.at("fy").get<double>();
  c.cx = attrs.at("cx").get<double>();
  c.cy = attrs.at("cy").get<double>();
  if (const Json* terms = fields::find(attrs, "distortion")) {
    const std::array<double*, kModelledTerms> modelled = {&c.k1, &c.k2, &c.p1,
                                                          &c.p2, &c.k3};
    for (std::size_t i = 0; i < terms->size() && i < kModelledTerms; ++i)
      *modelled[i] = (*terms)[i].get<double>();
  }
  c.source = attrs.at("source").get<std::string>();
  c.rms_px = fields::number(attrs, "rms_px").value_or(0);
  if (const Json* used = fields::find(attrs, "images_used"))
    c.images_used = used->get<int>();
  return c;
}

}  // namespace arscout::documents
