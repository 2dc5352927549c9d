#include "arscout/documents/model.h"

#include <utility>

#include "arscout/documents/capture_status.h"
#include "arscout/documents/document_error.h"
#include "json_fields.h"

namespace arscout::documents {
namespace {

using fields::Json;

constexpr std::pair<const char*, double ModelTimings::*> kTimings[] = {
    {"decode_s", &ModelTimings::decode_s},
    {"undistort_s", &ModelTimings::undistort_s},
    {"features_s", &ModelTimings::features_s},
    {"matching_s", &ModelTimings::matching_s},
    {"pose_s", &ModelTimings::pose_s},
    {"triangulation_s", &ModelTimings::triangulation_s},
    {"bundle_adjustment_s", &ModelTimings::bundle_adjustment_s},
    {"sparse_s", &ModelTimings::sparse_s},
    {"sweep_s", &ModelTimings::sweep_s},
    {"filter_s", &ModelTimings::filter_s},
    {"fusion_s", &ModelTimings::fusion_s},
    {"total_s", &ModelTimings::total_s}};

constexpr std::pair<const char*, std::size_t ModelStatistics::*> kCounts[] = {
    {"captures", &ModelStatistics::captures},
    // Captures by status, under the status's word.
    {kRegisteredCount, &ModelStatistics::registered},
    {to_string(CaptureStatus::kPending), &ModelStatistics::pending},
    {to_string(CaptureStatus::kRejected), &ModelStatistics::rejected},
    {"sparse_points", &ModelStatistics::sparse_points},
    {"dense_points", &ModelStatistics::dense_points},
    {"depth_maps", &ModelStatistics::depth_maps}};

Json statuses_json(const std::map<std::string, CaptureStatus>& statuses) {
  Json j = Json::object();
  for (const auto& [id, status] : statuses) j[id] = to_string(status);
  return j;
}

Json geo_json(const GeoPoint& p) {
  return {{"lat", p.lat}, {"lon", p.lon}, {"alt", p.alt}};
}

std::optional<GeoPoint> geo_from_json(const Json& parent, const char* key) {
  const Json* j = fields::find(parent, key);
  if (!j) return std::nullopt;
  return GeoPoint{fields::number(*j, "lat").value_or(0),
                  fields::number(*j, "lon").value_or(0),
                  fields::number(*j, "alt").value_or(0)};
}

Json image_json(const ModelImageEntry& image) {
  Json j = {{"id", image.id},
            {"camera", image.camera},
            {"qvec", image.qvec},
            {"tvec", image.tvec},
            {"centre", image.centre}};
  if (image.geodetic) j["geodetic"] = geo_json(*image.geodetic);
  if (image.dense) j["dense"] = *image.dense;
  if (image.component) j["component"] = *image.component;
  return j;
}

ModelImageEntry image_from_json(const Json& j) {
  try {
    ModelImageEntry image;
    image.id = j.at("id").get<std::string>();
    image.camera = j.at("camera").get<std::string>();
    image.qvec = j.at("qvec").get<std::array<double, 4>>();
    image.tvec = j.at("tvec").get<std::array<double, 3>>();
    image.centre = j.at("centre").get<std::array<double, 3>>();
    image.geodetic = geo_from_json(j, "geodetic");
    if (const Json* dense = fields::find(j, "dense");
        dense && dense->is_boolean())
      image.dense = dense->get<bool>();
    if (const Json* component = fields::find(j, "component");
        component && fields::is_whole_number(*component, 0))
      image.component = component->get<int>();
    return image;
  } catch (const Json::exception& e) {
    throw DocumentError(std::string("model: an image entry is incomplete (") +
                        e.what() + ")");
  }
}

Json statistics_json(const ModelStatistics& s) {
  Json j = Json::object();
  for (const auto& [name, member] : kCounts) j[name] = s.*member;
  j["mean_reprojection_px"] = s.mean_reprojection_px;
  return j;
}

ModelStatistics statistics_from_json(const Json& attrs) {
  ModelStatistics s;
  const Json* j = fields::find(attrs, "statistics");
  if (!j) return s;
  for (const auto& [name, member] : kCounts)
    s.*member = static_cast<std::size_t>(fields::number(*j, name).value_or(0));
  s.mean_reprojection_px =
      fields::number(*j, "mean_reprojection_px").value_or(0);
  return s;
}

std::vector<std::string> strings_at(const Json& parent, const char* key) {
  std::vector<std::string> out;
  const Json* list = fields::find(parent, key);
  if (list && list->is_array())
    for (const Json& s : *list)
      if (s.is_string()) out.push_back(s.get<std::string>());
  return out;
}

}  // namespace

const ModelCameraEntry* ModelDocument::camera_of(
    const ModelImageEntry& image) const {
  for (const ModelCameraEntry& c : cameras)
    if (c.id == image.camera) return &c;
  return nullptr;
}

const ModelImageEntry* ModelDocument::image(const std::string& id) const {
  for (const ModelImageEntry& i : images)
    if (i.id == id) return &i;
  return nullptr;
}

Json to_json(const ModelDocument& m) {
  Json j = {{"site", m.site},
            {"frame", m.geo_registered ? "enu" : "local"},
            {"geo_registered", m.geo_registered},
            {"cameras", Json::array()},
            {"images", Json::array()},
            {"captures", statuses_json(m.capture_statuses)},
            {"statistics", statistics_json(m.statistics)},
            {"increment", {{"added", m.added}, {"withdrawn", m.withdrawn}}},
            {"timings", Json::object()}};
  if (m.enu_origin) j["enu_origin"] = geo_json(*m.enu_origin);
  for (const ModelCameraEntry& c : m.cameras) {
    Json camera = to_json(c.camera);
    camera["id"] = c.id;
    j["cameras"].push_back(std::move(camera));
  }
  for (const ModelImageEntry& i : m.images)
    j["images"].push_back(image_json(i));
  j["components"] = Json::array();
  for (const ModelComponentEntry& c : m.components)
    j["components"].push_back(
        {{"id", c.id}, {"images", c.images}, {"points", c.points}});
  for (const auto& [name, member] : kTimings)
    j["timings"][name] = m.timings.*member;
  if (!m.dense_state.empty()) j["dense_state"] = m.dense_state;
  if (!m.dense_tiles.is_null()) j["dense_tiles"] = m.dense_tiles;
  if (!m.mesh_tiles.is_null()) j["mesh_tiles"] = m.mesh_tiles;
  return j;
}

ModelDocument model_from_json(const Json& attrs) {
  if (!attrs.is_object())
    throw DocumentError("model: the attributes must be a JSON object");
  ModelDocument m;
  m.site = fields::string_or(attrs, "site");
  const Json* geo = fields::find(attrs, "geo_registered");
  m.geo_registered = geo && geo->is_boolean() && geo->get<bool>();
  m.enu_origin = geo_from_json(attrs, "enu_origin");
  if (const Json* cameras = fields::find(attrs, "cameras"))
    for (const Json& c : *cameras)
      m.cameras.push_back({fields::string_or(c, "id"), camera_from_json(c)});
  if (const Json* images = fields::find(attrs, "images"))
    for (const Json& i : *images) m.images.push_back(image_from_json(i));
  if (const Json* components = fields::find(attrs, "components");
      components && components->is_array())
    for (const Json& c : *components)
      m.components.push_back(
          {static_cast<int>(fields::number(c, "id").value_or(0)),
           static_cast<std::size_t>(fields::number(c, "images").value_or(0)),
           static_cast<std::size_t>(fields::number(c, "points").value_or(0))});
  if (const Json* statuses = fields::find(attrs, "captures"))
    for (const auto& [id, status] : statuses->items())
      if (status.is_string())  // words of other versions are left out
        if (auto known = capture_status_of(status.get<std::string>()))
          m.capture_statuses[id] = *known;
  m.statistics = statistics_from_json(attrs);
  if (const Json* increment = fields::find(attrs, "increment")) {
    m.added = strings_at(*increment, "added");
    m.withdrawn = strings_at(*increment, "withdrawn");
  }
  if (const Json* timings = fields::find(attrs, "timings"))
    for (const auto& [name, member] : kTimings)
      m.timings.*member = fields::number(*timings, name).value_or(0);
  m.dense_state = fields::string_or(attrs, "dense_state");
  if (const Json* tiles = fields::find(attrs, "dense_tiles"))
    m.dense_tiles = *tiles;
  if (const Json* tiles = fields::find(attrs, "mesh_tiles"))
    m.mesh_tiles = *tiles;
  return m;
}

}  // namespace arscout::documents
