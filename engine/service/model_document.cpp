#include "model_document.h"

#include "arscout/engine/ply.h"

namespace arscout::engine::service {
namespace {

Json camera_json(const ModelCamera& camera) {
  const CameraIntrinsics& k = camera.intrinsics;
  return {{"id", camera.id},    {"width", k.width},
          {"height", k.height}, {"fx", k.fx},
          {"fy", k.fy},         {"cx", k.cx},
          {"cy", k.cy},         {"distortion", {k.k1, k.k2, k.p1, k.p2, k.k3}},
          {"source", k.source}};
}

Json image_json(const ModelImage& image, const Model& model,
                const std::set<std::string>* dense_views) {
  Json j = {{"id", image.id},
            {"camera", model.cameras.at(image.camera).id},
            {"qvec", image.qvec},
            {"tvec", image.tvec},
            {"centre", image.centre}};
  if (image.geodetic)
    j["geodetic"] = {{"lat", image.geodetic->lat},
                     {"lon", image.geodetic->lon},
                     {"alt", image.geodetic->alt}};
  if (dense_views) j["dense"] = dense_views->count(image.id) > 0;
  return j;
}

Json timings_json(const IncrementReport& r) {
  const StageTimings& s = r.sparse;
  return {{"decode_s", s.decode_s},
          {"undistort_s", s.undistort_s},
          {"features_s", s.features_s},
          {"matching_s", s.matching_s},
          {"pose_s", s.pose_s},
          {"triangulation_s", s.triangulation_s},
          {"bundle_adjustment_s", s.bundle_adjustment_s},
          {"sparse_s", s.total_s},
          {"sweep_s", r.dense.sweep_s},
          {"filter_s", r.dense.filter_s},
          {"fusion_s", r.dense.fusion_s},
          {"total_s", r.total_s}};
}

}  // namespace

Json model_attrs(const std::string& site, const Model& model,
                 const std::vector<CaptureState>& captures,
                 const IncrementReport& report,
                 const std::set<std::string>* dense_views) {
  Json attrs;
  attrs["site"] = site;
  attrs["frame"] = model.geo_registered ? "enu" : "local";
  attrs["geo_registered"] = model.geo_registered;
  if (model.enu_origin)
    attrs["enu_origin"] = {{"lat", model.enu_origin->lat},
                           {"lon", model.enu_origin->lon},
                           {"alt", model.enu_origin->alt}};
  Json cameras = Json::array(), images = Json::array();
  for (const ModelCamera& c : model.cameras) cameras.push_back(camera_json(c));
  for (const ModelImage& i : model.images)
    images.push_back(image_json(i, model, dense_views));
  attrs["cameras"] = std::move(cameras);
  attrs["images"] = std::move(images);
  Json status = Json::object();
  int rejected = 0, pending = 0;
  for (const CaptureState& c : captures) {
    status[c.id] = to_string(c.status);
    rejected += c.status == CaptureStatus::kRejected;
    pending += c.status == CaptureStatus::kPending;
  }
  attrs["captures"] = std::move(status);
  attrs["statistics"] = {{"captures", captures.size()},
                         {"registered", model.images.size()},
                         {"pending", pending},
                         {"rejected", rejected},
                         {"sparse_points", model.points.size()},
                         {"dense_points", report.dense_points},
                         {"depth_maps", report.dense.new_depth_maps.size()},
                         {"mean_reprojection_px", model.mean_reprojection_px}};
  attrs["increment"] = {{"added", report.added},
                        {"withdrawn", report.withdrawn}};
  attrs["timings"] = timings_json(report);
  return attrs;
}

std::string sparse_ply(const Model& model) {
  std::vector<ColoredPoint> points;
  points.reserve(model.points.size());
  for (const ModelPoint& p : model.points) {
    ColoredPoint c;
    c.x = static_cast<float>(p.xyz[0]);
    c.y = static_cast<float>(p.xyz[1]);
    c.z = static_cast<float>(p.xyz[2]);
    c.r = p.rgb[0];
    c.g = p.rgb[1];
    c.b = p.rgb[2];
    points.push_back(c);
  }
  return encode_ply(points, "arscout sparse model");
}

}  // namespace arscout::engine::service
