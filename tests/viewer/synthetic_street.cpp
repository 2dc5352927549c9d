#include "synthetic_street.h"

#include <algorithm>
#include <cmath>
#include <random>

#include <nlohmann/json.hpp>

#include <Eigen/Geometry>

#include "arscout/documents/model.h"
#include "arscout/documents/site.h"

namespace street_cloud {
namespace {

using arscout::engine::ColoredPoint;
using Vec3 = std::array<double, 3>;

// A rectangle: corner + u * [0,1] + v * [0,1], and how it is coloured.
struct Patch {
  Vec3 corner, u, v;
  enum Look { kAsphalt, kPavement, kWall, kRoof } look;
  std::array<std::uint8_t, 3> base;
};

double length(const Vec3& a) { return std::hypot(a[0], a[1], a[2]); }

void add_box(std::vector<Patch>* out, Vec3 lo, Vec3 hi,
             std::array<std::uint8_t, 3> wall) {
  const double dx = hi[0] - lo[0], dy = hi[1] - lo[1], dz = hi[2] - lo[2];
  const std::array<std::uint8_t, 3> roof{150, 70, 55};
  out->push_back({lo, {dx, 0, 0}, {0, 0, dz}, Patch::kWall, wall});
  out->push_back(
      {{lo[0], hi[1], lo[2]}, {dx, 0, 0}, {0, 0, dz}, Patch::kWall, wall});
  out->push_back({lo, {0, dy, 0}, {0, 0, dz}, Patch::kWall, wall});
  out->push_back(
      {{hi[0], lo[1], lo[2]}, {0, dy, 0}, {0, 0, dz}, Patch::kWall, wall});
  out->push_back(
      {{lo[0], lo[1], hi[2]}, {dx, 0, 0}, {0, dy, 0}, Patch::kRoof, roof});
}

std::vector<Patch> street_patches() {
  std::vector<Patch> patches;
  patches.push_back(
      {{-50, -6, 0}, {100, 0, 0}, {0, 12, 0}, Patch::kAsphalt, {70, 72, 76}});
  patches.push_back({{-50, -9, 0},
                     {100, 0, 0},
                     {0, 3, 0},
                     Patch::kPavement,
                     {170, 165, 155}});
  patches.push_back(
      {{-50, 6, 0}, {100, 0, 0}, {0, 3, 0}, Patch::kPavement, {170, 165, 155}});
  // The measured house first, then its neighbours along both sides.
  add_box(&patches, {0, 9, 0}, {10, 17, 12}, {205, 185, 140});
  const double north[][3] = {
      {-24, -12, 9}, {-10, -1, 15}, {12, 22, 8}, {24, 38, 14}};
  for (const auto& h : north)
    add_box(&patches, {h[0], 10, 0}, {h[1], 18, h[2]}, {180, 175, 170});
  const double south[][3] = {
      {-45, -30, 11}, {-28, -12, 7}, {-8, 6, 13}, {9, 20, 10}, {23, 44, 16}};
  for (const auto& h : south)
    add_box(&patches, {h[0], -18, 0}, {h[1], -10, h[2]}, {190, 160, 150});
  return patches;
}

// Windows on walls (a grid of darker panes), marks on the asphalt.
std::array<std::uint8_t, 3> colour_at(const Patch& p, double s, double t) {
  const double along = s * length(p.u), up = t * length(p.v);
  auto shade = [&](double f) {
    return std::array<std::uint8_t, 3>{
        static_cast<std::uint8_t>(p.base[0] * f),
        static_cast<std::uint8_t>(p.base[1] * f),
        static_cast<std::uint8_t>(p.base[2] * f)};
  };
  if (p.look == Patch::kWall) {
    const bool pane = std::fmod(along, 3.0) > 1.0 &&
                      std::fmod(along, 3.0) < 2.2 && std::fmod(up, 3.0) > 1.0 &&
                      std::fmod(up, 3.0) < 2.4 && up > 0.8;
    return pane ? std::array<std::uint8_t, 3>{60, 80, 100} : p.base;
  }
  if (p.look == Patch::kAsphalt) {
    const bool mark = std::fabs(up - 6) < 0.08 && std::fmod(along, 6.0) < 3.0;
    return mark ? std::array<std::uint8_t, 3>{235, 235, 225} : p.base;
  }
  if (p.look == Patch::kRoof)
    return shade(std::fmod(along, 0.5) < 0.25 ? 0.9 : 1.0);
  return shade(std::fmod(along, 1.0) < 0.05 || std::fmod(up, 1.0) < 0.05 ? 0.8
                                                                         : 1.0);
}

}  // namespace

std::vector<ColoredPoint> synthetic_street(std::size_t count,
                                           std::uint32_t seed) {
  const std::vector<Patch> patches = street_patches();
  std::vector<double> areas;
  for (const Patch& p : patches) {
    const Vec3 n{p.u[1] * p.v[2] - p.u[2] * p.v[1],
                 p.u[2] * p.v[0] - p.u[0] * p.v[2],
                 p.u[0] * p.v[1] - p.u[1] * p.v[0]};
    areas.push_back(length(n));
  }
  std::mt19937 rng(seed);
  std::discrete_distribution<std::size_t> pick(areas.begin(), areas.end());
  std::uniform_real_distribution<double> unit(0, 1);
  std::vector<ColoredPoint> points(count);
  for (ColoredPoint& q : points) {
    const Patch& p = patches[pick(rng)];
    const double s = unit(rng), t = unit(rng);
    const auto c = colour_at(p, s, t);
    q.x = static_cast<float>(p.corner[0] + s * p.u[0] + t * p.v[0]);
    q.y = static_cast<float>(p.corner[1] + s * p.u[1] + t * p.v[1]);
    q.z = static_cast<float>(p.corner[2] + s * p.u[2] + t * p.v[2]);
    q.r = c[0];
    q.g = c[1];
    q.b = c[2];
  }
  return points;
}

namespace {

using Json = nlohmann::json;

constexpr std::size_t kTilePoints = 1'000'000;
const arscout::documents::GeoPoint kOrigin{47.0707, 15.4395, 353.0};

// The dense cloud's tiles as the model document names them.
Json store_tiles(arscout::db::Store& store,
                 const std::vector<ColoredPoint>& cloud) {
  Json tiles = Json::array();
  for (std::size_t at = 0; at < cloud.size(); at += kTilePoints) {
    const std::size_t end = std::min(cloud.size(), at + kTilePoints);
    const std::vector<ColoredPoint> tile(cloud.begin() + at,
                                         cloud.begin() + end);
    const std::string blob = store.put_blob(
        arscout::engine::encode_ply(tile, "arscout synthetic street tile"));
    tiles.push_back({{"tile", std::to_string(at / kTilePoints)},
                     {"blob", blob},
                     {"points", tile.size()},
                     {"hash", "0"}});
  }
  return tiles;
}

// Six cameras 1.6 m up along the street's axis, looking north (component
// 0, x 5..30 m) or south (component 1, x 60..85 m).
void add_component_cameras(arscout::documents::ModelDocument* model) {
  arscout::documents::ModelCameraEntry camera;
  camera.id = "phone";
  camera.camera.width = 1600;
  camera.camera.height = 1200;
  camera.camera.fx = camera.camera.fy = 1400;
  camera.camera.cx = 800;
  camera.camera.cy = 600;
  model->cameras.push_back(camera);
  for (int component = 0; component < 2; ++component) {
    const double facing = component == 0 ? 1 : -1;  // +y or -y
    Eigen::Matrix3d r;  // world-to-camera: rows are the camera's axes
    r << facing, 0, 0, 0, 0, -1, 0, facing, 0;
    const Eigen::Quaterniond q(r);
    for (int i = 0; i < 6; ++i) {
      arscout::documents::ModelImageEntry image;
      image.id = "c" + std::to_string(component) + "-" + std::to_string(i);
      image.camera = camera.id;
      const Eigen::Vector3d centre(5.0 + 55 * component + 5 * i, 0, 1.6);
      const Eigen::Vector3d t = -(r * centre);
      image.qvec = {q.w(), q.x(), q.y(), q.z()};
      image.tvec = {t.x(), t.y(), t.z()};
      image.centre = {centre.x(), centre.y(), centre.z()};
      image.component = component;
      model->images.push_back(image);
    }
    model->components.push_back({component, 6, 0});
  }
}

// "{site}-before": a site that grew into `site`.
void write_merged_site(arscout::db::Store& store, const std::string& site) {
  arscout::documents::Site doc;
  doc.name = "synthetic " + site + " (before)";
  doc.radius_m = 100;
  doc.state = "merged";
  doc.merged_into = site;
  store.put("/sites/" + site + "-before", "site", to_json(doc));
}

}  // namespace

void write_street_site(arscout::db::Store& store, const std::string& site,
                       const std::vector<ColoredPoint>& cloud,
                       bool components) {
  arscout::documents::ModelDocument model;
  model.site = site;
  model.geo_registered = true;
  model.enu_origin = kOrigin;
  model.statistics.dense_points = cloud.size();
  model.dense_state = "current";
  model.dense_tiles = store_tiles(store, cloud);
  if (components) add_component_cameras(&model);
  arscout::db::WriteOp put = arscout::db::WriteOp::put(
      "/sites/" + site + "/model", "model", to_json(model));
  const std::vector<ColoredPoint> sparse(
      cloud.begin(), cloud.begin() + std::min<std::size_t>(cloud.size(), 5000));
  put.blobs = arscout::db::BlobRefs{
      {"sparse", store.put_blob(arscout::engine::encode_ply(sparse))}};
  const std::int64_t version = store.write(put).version;
  arscout::documents::Site doc;
  doc.name = "synthetic " + site;
  doc.radius_m = 100;
  doc.centre = kOrigin;
  doc.model_version = version;
  doc.state = "modelled";
  store.put("/sites/" + site, "site", to_json(doc));
  if (components) write_merged_site(store, site);
}

}  // namespace street_cloud
