#include "capture_document.h"

namespace arscout::engine::service {

using Json = nlohmann::json;

std::optional<GeoFix> capture_fix(const Json& attrs) {
  const Json gps = attrs.value("gps", Json());
  if (!gps.is_object() || !gps.contains("lat") || !gps.contains("lon") ||
      !gps.at("lat").is_number() || !gps.at("lon").is_number())
    return std::nullopt;
  GeoFix fix;
  fix.lat = gps.at("lat").get<double>();
  fix.lon = gps.at("lon").get<double>();
  if (gps.contains("alt") && gps.at("alt").is_number())
    fix.alt = gps.at("alt").get<double>();
  if (gps.contains("h_acc") && gps.at("h_acc").is_number())
    fix.h_acc = gps.at("h_acc").get<double>();
  if (gps.contains("v_acc") && gps.at("v_acc").is_number())
    fix.v_acc = gps.at("v_acc").get<double>();
  return fix;
}

std::optional<CameraIntrinsics> camera_intrinsics(const Json& attrs) {
  CameraIntrinsics k;
  try {
    k.width = attrs.at("width").get<int>();
    k.height = attrs.at("height").get<int>();
    k.fx = attrs.at("fx").get<double>();
    k.fy = attrs.at("fy").get<double>();
    k.cx = attrs.at("cx").get<double>();
    k.cy = attrs.at("cy").get<double>();
    const Json d = attrs.value("distortion", Json::array());
    double* terms[] = {&k.k1, &k.k2, &k.p1, &k.p2, &k.k3};
    for (size_t i = 0; i < 5 && i < d.size(); ++i)
      *terms[i] = d[i].get<double>();
    k.source = attrs.value("source", "calibrated");
  } catch (const Json::exception&) {
    return std::nullopt;
  }
  if (!validate(k).empty()) return std::nullopt;
  return k;
}

}  // namespace arscout::engine::service
