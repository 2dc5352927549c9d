// The GPS fix, capture, site, engine state and model forms: each written and
// read back through JSON text, and what their readers do with what other
// versions or hands may have stored.
#include <gtest/gtest.h>

#include <cmath>

#include <nlohmann/json.hpp>

#include "arscout/documents/capture.h"
#include "arscout/documents/document_error.h"
#include "arscout/documents/engine_state.h"
#include "arscout/documents/geojson.h"
#include "arscout/documents/gps.h"
#include "arscout/documents/model.h"
#include "arscout/documents/site.h"

namespace arscout::documents {
namespace {

using Json = nlohmann::json;

Json through_text(const Json& j) { return Json::parse(j.dump()); }

GpsFix fix() {
  return GpsFix{47.0707, 15.4395, 353.5, 3.5, 7.0, 9, "2026-11-21T13:05:00Z",
                "csv"};
}

TEST(GpsForm, RoundTripsAndNamesTheBadField) {
  const auto read = gps_from_json(through_text(to_json(fix())));
  ASSERT_TRUE(read);
  EXPECT_EQ(to_json(*read), to_json(fix()));
  std::string error;
  Json bad = to_json(fix());
  bad["h_acc"] = -1;
  EXPECT_FALSE(gps_from_json(bad, &error));
  EXPECT_NE(error.find("h_acc"), std::string::npos) << error;
  bad = to_json(fix());
  bad["time"] = "yesterday";
  EXPECT_FALSE(gps_from_json(bad, &error));
  EXPECT_NE(error.find("time"), std::string::npos) << error;
  EXPECT_FALSE(gps_from_json(Json{{"lat", 47}}, &error));
}

Capture capture() {
  Capture c;
  c.scout = "alice";
  c.received = "2026-11-21T13:05:02Z";
  c.format = "jpeg";
  c.width = 3072;
  c.height = 2048;
  c.bytes = 1234567;
  c.status = CaptureStatus::kStored;
  c.taken = "2026-11-21T13:05:00Z";
  c.gps = fix();
  c.camera = "fountain";
  c.filename = "0001.jpg";
  c.exif.focal_35mm = 28;
  c.exif.make = "Pixel";
  return c;
}

TEST(CaptureForm, RoundTrips) {
  const Json written = through_text(to_json(capture()));
  EXPECT_FALSE(written.contains("site_hint"));  // empty fields left out
  EXPECT_FALSE(written.contains("site"));
  EXPECT_EQ(to_json(capture_from_json(written)), written);
}

TEST(CaptureForm, ReadsLenientlyAndPatchesStatus) {
  const Json odd = {{"scout", 7}, {"width", -3}, {"gps", {{"lat", 200}}}};
  const Capture c = capture_from_json(odd);
  EXPECT_EQ(c.scout, "");
  EXPECT_EQ(c.width, 0);
  EXPECT_FALSE(c.gps);  // not a valid fix: none
  EXPECT_THROW(capture_from_json(Json::array()), DocumentError);
  Json doc = to_json(capture());
  doc.merge_patch(status_patch(CaptureStatus::kRejected, "no GPS", "s-a"));
  const Capture patched = capture_from_json(doc);
  EXPECT_EQ(patched.status, CaptureStatus::kRejected);
  EXPECT_EQ(patched.status_reason, "no GPS");
  EXPECT_EQ(patched.site, "s-a");
}

TEST(SiteForm, RoundTrips) {
  Site s;
  s.name = "fountain";
  s.radius_m = 50;
  s.fixes = 11;
  s.extent_m = 12.5;
  s.reach_m = 20;
  s.cameras = 9;
  s.captures = {"alice.0000.jpg", "alice.0001.jpg"};
  s.centre = GeoPoint{47.07, 15.44, 353};
  s.registered = 2;
  s.model_version = 3;
  s.state = "modelled";
  s.engine = "engine-1";
  const Json written = through_text(to_json(s));
  EXPECT_EQ(written["capture_count"], 2);
  EXPECT_EQ(to_json(site_from_json(written, "s-alice.0000.jpg")), written);
  const Site bare = site_from_json(Json::object(), "s-x");
  EXPECT_EQ(bare.name, "s-x");
  EXPECT_FALSE(bare.centre);
  // Stored before the footprint followed cameras: it reaches its extent.
  EXPECT_DOUBLE_EQ(site_from_json(Json{{"extent_m", 30}}, "s-y").reach_m, 30);
  EXPECT_THROW(site_from_json(Json{{"captures", {1, 2}}}, "s-x"),
               DocumentError);
}

ModelDocument model() {
  ModelDocument m;
  m.site = "s-a";
  m.geo_registered = true;
  m.enu_origin = GeoPoint{47.07, 15.44, 353};
  Camera k;
  k.width = 640;
  k.height = 480;
  k.fx = k.fy = 500;
  k.cx = 319.5;
  k.cy = 239.5;
  k.k1 = -0.1;
  m.cameras.push_back({"phone", k});
  ModelImageEntry image;
  image.id = "alice.0000.jpg";
  image.camera = "phone";
  image.qvec = {0.5, 0.5, 0.5, 0.5};
  image.tvec = {1, 2, 3};
  image.centre = {-1, -2, -3};
  image.geodetic = GeoPoint{47.0701, 15.4402, 354};
  image.dense = true;
  m.images.push_back(image);
  m.capture_statuses = {{"alice.0000.jpg", CaptureStatus::kRegistered}};
  m.statistics.captures = 1;
  m.statistics.registered = 1;
  m.statistics.sparse_points = 120;
  m.statistics.mean_reprojection_px = 0.4;
  m.added = {"alice.0000.jpg"};
  m.timings.features_s = 0.2;
  m.timings.total_s = 0.9;
  m.dense_state = "current";
  m.dense_tiles = Json::array({{{"tile", "0_0_0"}}});
  return m;
}

TEST(EngineStateForm, RoundTripsExactlyAndDefaultsWhatIsMissing) {
  EngineState state;
  state.statuses = {{"alice.a", "registered"}, {"bob.b", "failed"}};
  state.registered = 1;
  state.through_seq = (std::int64_t{1} << 60) + 1;  // past a double's
  state.dense_due = true;
  const EngineState read = engine_state_from_json(through_text(to_json(state)));
  EXPECT_EQ(read.statuses, state.statuses);
  EXPECT_EQ(read.registered, 1);
  EXPECT_EQ(read.through_seq, state.through_seq);
  EXPECT_TRUE(read.dense_due);
  EXPECT_EQ(to_json(read), to_json(state));

  const EngineState bare = engine_state_from_json(Json::object());
  EXPECT_TRUE(bare.statuses.empty());
  EXPECT_EQ(bare.through_seq, 0);
  EXPECT_FALSE(bare.dense_due);
  // A dense phase's patch, applied, reads back as the flag it wrote.
  Json patched = to_json(state);
  patched.merge_patch(dense_due_patch(false));
  EXPECT_FALSE(engine_state_from_json(patched).dense_due);
  EXPECT_EQ(engine_state_from_json(patched).statuses, state.statuses);

  EXPECT_THROW(engine_state_from_json(Json::array()), DocumentError);
  EXPECT_THROW(engine_state_from_json(Json{{"statuses", {"a", "b"}}}),
               DocumentError);
  EXPECT_THROW(engine_state_from_json(Json{{"statuses", {{"a", 3}}}}),
               DocumentError);
}

// Cameras looking north, east and straight down (world-to-camera
// quaternions w x y z, ENU world), and one with no geodetic position.
TEST(GeoJson, CamerasSitAtTheirPositionsLookingTheirWay) {
  ModelDocument model;
  model.site = "s1";
  const std::array<std::array<double, 4>, 3> looks = {
      {{std::sqrt(0.5), std::sqrt(0.5), 0, 0},
       {0.5, 0.5, -0.5, 0.5},
       {0, 1, 0, 0}}};
  for (int i = 0; i < 4; ++i) {
    ModelImageEntry image;
    image.id = "a." + std::to_string(i);
    image.camera = "c";
    image.qvec = looks[i % 3];
    if (i < 3) image.geodetic = GeoPoint{47.0 + i, 15.0, 350.0};
    model.images.push_back(image);
  }
  EXPECT_THROW(cameras_geojson(model), DocumentError);  // frame: local
  model.geo_registered = true;
  const Json map = through_text(cameras_geojson(model));
  ASSERT_EQ(map.at("features").size(), 3u);
  const Json& north = map["features"][0];
  EXPECT_EQ(north["id"], "a.0");
  EXPECT_EQ(north["geometry"]["coordinates"], Json({15.0, 47.0, 350.0}));
  EXPECT_NEAR(north["properties"]["heading_deg"].get<double>(), 0, 1e-9);
  EXPECT_NEAR(north["properties"]["pitch_deg"].get<double>(), 0, 1e-9);
  EXPECT_NEAR(map["features"][1]["properties"]["heading_deg"].get<double>(), 90,
              1e-9);
  EXPECT_NEAR(map["features"][2]["properties"]["pitch_deg"].get<double>(), -90,
              1e-9);
}

TEST(GeoJson, SitesArePointsOrNullBeforeTheirFirstFix) {
  Site placed;
  placed.name = "graz";
  placed.captures = {"a.1", "a.2"};
  placed.centre = GeoPoint{47.07, 15.44, 353};
  const Json map =
      through_text(sites_geojson({{"s-graz", placed}, {"s-new", Site{}}}));
  EXPECT_EQ(map["type"], "FeatureCollection");
  ASSERT_EQ(map["features"].size(), 2u);
  EXPECT_EQ(map["features"][0]["geometry"]["coordinates"],
            Json({15.44, 47.07, 353.0}));
  EXPECT_EQ(map["features"][0]["properties"]["captures"], 2);
  EXPECT_TRUE(map["features"][1]["geometry"].is_null());
}

TEST(ModelForm, RoundTrips) {
  const Json written = through_text(to_json(model()));
  EXPECT_EQ(written["frame"], "enu");
  EXPECT_EQ(written["cameras"][0]["id"], "phone");
  EXPECT_EQ(written["timings"].size(), 12u);
  const ModelDocument read = model_from_json(written);
  EXPECT_EQ(to_json(read), written);
  ASSERT_NE(read.image("alice.0000.jpg"), nullptr);
  EXPECT_EQ(read.camera_of(*read.image("alice.0000.jpg"))->camera.k1, -0.1);
  EXPECT_EQ(read.image("nobody"), nullptr);
}

TEST(ModelForm, AnEmptyModelKeepsItsShape) {
  ModelDocument empty;
  empty.site = "s-b";
  const Json written = through_text(to_json(empty));
  EXPECT_TRUE(written["captures"].is_object());
  EXPECT_TRUE(written["images"].is_array());
  EXPECT_FALSE(written.contains("dense_state"));
  EXPECT_EQ(to_json(model_from_json(written)), written);
}

TEST(ModelForm, RefusesABrokenCameraOrImage) {
  Json broken = to_json(model());
  broken["cameras"][0]["distortion"] = {0, 0, 0, 0, 0, 0.2};
  EXPECT_THROW(model_from_json(broken), DocumentError);
  broken = to_json(model());
  broken["images"][0].erase("qvec");
  EXPECT_THROW(model_from_json(broken), DocumentError);
}

}  // namespace
}  // namespace arscout::documents
