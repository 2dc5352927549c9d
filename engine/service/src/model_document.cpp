#include "model_document.h"

#include "arscout/engine/ply.h"

namespace arscout::engine::service {
namespace {

documents::GeoPoint geo_point(const Geodetic& g) {
  return {g.lat, g.lon, g.alt};
}

documents::ModelImageEntry image_entry(
    const ModelImage& image, const Model& model,
    const std::set<std::string>* dense_views) {
  documents::ModelImageEntry entry;
  entry.id = image.id;
  entry.camera = model.cameras.at(image.camera).id;
  entry.qvec = image.qvec;
  entry.tvec = image.tvec;
  entry.centre = image.centre;
  if (image.geodetic) entry.geodetic = geo_point(*image.geodetic);
  if (dense_views) entry.dense = dense_views->count(image.id) > 0;
  entry.component = image.component;
  return entry;
}

documents::ModelTimings timings(const IncrementReport& r) {
  const StageTimings& s = r.sparse;
  documents::ModelTimings t;
  t.decode_s = s.decode_s;
  t.undistort_s = s.undistort_s;
  t.features_s = s.features_s;
  t.matching_s = s.matching_s;
  t.pose_s = s.pose_s;
  t.triangulation_s = s.triangulation_s;
  t.bundle_adjustment_s = s.bundle_adjustment_s;
  t.sparse_s = s.total_s;
  t.sweep_s = r.dense.sweep_s;
  t.filter_s = r.dense.filter_s;
  t.fusion_s = r.dense.fusion_s;
  t.total_s = r.total_s;
  return t;
}

documents::ModelStatistics statistics(const Model& model,
                                      const std::vector<CaptureState>& captures,
                                      const IncrementReport& report) {
  documents::ModelStatistics s;
  s.captures = captures.size();
  s.registered = model.images.size();
  for (const CaptureState& c : captures) {
    s.rejected += c.status == CaptureStatus::kRejected;
    s.pending += c.status == CaptureStatus::kPending;
  }
  s.sparse_points = model.points.size();
  s.dense_points = report.dense_points;
  s.depth_maps = report.dense.new_depth_maps.size();
  s.mean_reprojection_px = model.mean_reprojection_px;
  return s;
}

}  // namespace

documents::ModelDocument model_document(
    const std::string& site, const Model& model,
    const std::vector<CaptureState>& captures, const IncrementReport& report,
    const std::set<std::string>* dense_views) {
  documents::ModelDocument doc;
  doc.site = site;
  doc.geo_registered = model.geo_registered;
  if (model.enu_origin) doc.enu_origin = geo_point(*model.enu_origin);
  for (const ModelCamera& c : model.cameras)
    doc.cameras.push_back({c.id, c.intrinsics});
  for (const ModelImage& i : model.images)
    doc.images.push_back(image_entry(i, model, dense_views));
  for (const ModelComponent& c : model.components)
    doc.components.push_back({c.id, static_cast<std::size_t>(c.images),
                              static_cast<std::size_t>(c.points)});
  for (const CaptureState& c : captures) doc.capture_statuses[c.id] = c.status;
  doc.statistics = statistics(model, captures, report);
  doc.added = report.added;
  doc.withdrawn = report.withdrawn;
  doc.timings = timings(report);
  return doc;
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
