// Site placement: distance, footprints that follow registered cameras and
// reach (boundedly) along a walk not yet registered, hints, and ids that
// come out the same when a capture is placed again.
#include "site_directory.h"

#include <gtest/gtest.h>

#include <cmath>

#include "arscout/util/geodesy.h"

namespace arscout::engine::service {
namespace {

// A fix `north_m` metres north and `east_m` east of (47, 15).
GeoFix offset(double north_m, double east_m) {
  GeoFix fix;
  fix.lat = 47 + north_m / 111195.0;
  fix.lon = 15 + east_m / (111195.0 * std::cos(47 * M_PI / 180));
  fix.alt = 350;
  return fix;
}

TEST(SiteDirectory, DistanceIsGreatCircle) {
  const GeoFix a = offset(0, 0), b = offset(30, 40);
  EXPECT_NEAR(util::great_circle_m(a.lat, a.lon, b.lat, b.lon), 50, 0.2);
  // Graz to Lausanne, about 690 km.
  EXPECT_NEAR(util::great_circle_m(47.07, 15.44, 46.52, 6.57) / 1000, 677, 15);
}

TEST(SiteDirectory, NearCapturesShareASiteFarOnesFoundNewOnes) {
  SiteDirectory sites(50);
  const auto first = sites.place("a", offset(0, 0), "");
  ASSERT_TRUE(first);
  EXPECT_EQ(*first, "s-a");
  EXPECT_EQ(sites.place("b", offset(20, 10), ""), first);
  const auto far = sites.place("c", offset(5000, 0), "");
  ASSERT_TRUE(far);
  EXPECT_NE(*far, *first);
  EXPECT_EQ(sites.sites().size(), 2u);
  // Until a camera registers, the centre is the founding fix.
  const auto site = sites.site(*first);
  ASSERT_TRUE(site);
  const GeoFix a = offset(0, 0);
  EXPECT_NEAR(util::great_circle_m(site->lat, site->lon, a.lat, a.lon), 0,
              0.01);
  EXPECT_NEAR(site->reach_m, 22.36, 0.05);
  EXPECT_EQ(site->captures, (std::vector<std::string>{"a", "b"}));
}

TEST(SiteDirectory, AStreetWalkStaysOneSite) {
  // 29 photos 6 m apart: 170 m of street, as opensfm/lund.
  SiteDirectory sites(50);
  for (int i = 0; i < 29; ++i)
    sites.place("p" + std::to_string(i), offset(6.0 * i, 0), "");
  ASSERT_EQ(sites.sites().size(), 1u);
  EXPECT_NEAR(sites.sites()[0].reach_m, 168, 0.5);  // none registered yet
  // But a capture 150 m beyond its end founds another.
  sites.place("beyond", offset(6.0 * 28 + 60 + 90, 0), "");
  EXPECT_EQ(sites.sites().size(), 2u);
}

TEST(SiteDirectory, NearestSiteWins) {
  SiteDirectory sites(50);
  sites.place("west", offset(0, -40), "");
  sites.place("east", offset(0, 45), "");
  ASSERT_EQ(sites.sites().size(), 2u);
  EXPECT_EQ(sites.place("x", offset(0, 30), ""), "s-east");
  EXPECT_EQ(sites.place("y", offset(0, -20), ""), "s-west");
}

TEST(SiteDirectory, HintsPlaceCapturesWithoutAFix) {
  SiteDirectory sites(50);
  EXPECT_EQ(sites.place("a", std::nullopt, "graz campus"), "h-graz_campus");
  EXPECT_EQ(sites.place("b", std::nullopt, "graz campus"), "h-graz_campus");
  EXPECT_FALSE(sites.place("c", std::nullopt, ""));
  EXPECT_FALSE(sites.site_of("c"));
  // A hint-only site has no centre: fixes do not join it by distance.
  EXPECT_EQ(sites.place("d", offset(0, 0), ""), "s-d");
}

TEST(SiteDirectory, PlacingAgainGivesTheSameSiteAndSurvivesAReload) {
  SiteDirectory sites(50);
  sites.place("a", offset(0, 0), "");
  sites.place("b", offset(10, 0), "");
  EXPECT_EQ(sites.place("a", offset(900, 0), ""), "s-a");  // placed before
  std::map<std::string, Json> stored;
  for (const Site& s : sites.sites())
    stored[s.id] = documents::to_json(SiteDirectory::to_document(s, 50));
  SiteDirectory reloaded(50);
  reloaded.load(stored);
  EXPECT_EQ(reloaded.site_of("b"), "s-a");
  const auto site = reloaded.site("s-a");
  ASSERT_TRUE(site);
  EXPECT_EQ(site->fixes, 2);
  EXPECT_NEAR(site->reach_m, sites.site("s-a")->reach_m, 1e-9);
  EXPECT_EQ(reloaded.place("c", offset(30, 0), ""), "s-a");
}

// A footprint of `cameras` cameras around the fix `north_m` north.
Footprint cameras_at(double north_m, double extent_m, int cameras) {
  const GeoFix at = offset(north_m, 0);
  return Footprint{at.lat, at.lon, 350, extent_m, cameras};
}

double metres_between(const Site& site, const GeoFix& fix) {
  return util::great_circle_m(site.lat, site.lon, fix.lat, fix.lon);
}

TEST(SiteDirectory, TheFootprintFollowsRegisteredCameras) {
  SiteDirectory sites(50);
  for (int i = 0; i < 10; ++i)
    sites.place("p" + std::to_string(i), offset(4.0 * i, 0), "");
  // The engine registered the first six, spread over 20 m around 10 m
  // north; the last four wait: the reach still covers them.
  EXPECT_TRUE(sites.follow("s-p0", cameras_at(10, 10, 6),
                           {"p0", "p1", "p2", "p3", "p4", "p5"}));
  Site site = *sites.site("s-p0");
  EXPECT_NEAR(metres_between(site, offset(10, 0)), 0, 0.01);
  EXPECT_EQ(site.cameras, 6);
  EXPECT_DOUBLE_EQ(site.extent_m, 10);
  EXPECT_NEAR(site.reach_m, 26, 0.05);  // p9, 36 m north
  // Once they are processed without registering, the reach is the extent.
  sites.follow("s-p0", cameras_at(10, 10, 6), {"p6", "p7", "p8", "p9"});
  site = *sites.site("s-p0");
  EXPECT_DOUBLE_EQ(site.reach_m, 10);
  EXPECT_FALSE(sites.follow("nosuchsite", cameras_at(0, 0, 1), {}));
  // With no camera registered, only the unconfirmed fixes go.
  sites.place("q0", offset(0, 3000), "");
  sites.place("q1", offset(0, 3030), "");
  sites.follow("s-q0", Footprint{}, {"q1"});
  EXPECT_NEAR(metres_between(*sites.site("s-q0"), offset(0, 3000)), 0, 0.01);
}

TEST(SiteDirectory, FixesWalkingAwayFoundNewSitesInsteadOfDraggingOne) {
  // A registered site, then 400 junk captures whose fixes step 20 m north
  // each (8 km), all sent before the engine processed any of them.
  SiteDirectory sites(50);
  sites.place("fountain", offset(0, 0), "");
  sites.follow("s-fountain", cameras_at(0, 10, 11), {"fountain"});
  for (int i = 1; i <= 400; ++i)
    sites.place("junk" + std::to_string(i), offset(20.0 * i, 0), "");
  const Site fountain = *sites.site("s-fountain");
  EXPECT_NEAR(metres_between(fountain, offset(0, 0)), 0, 0.01);
  // Its reach is bounded: kUnconfirmedReach radii beyond its cameras.
  EXPECT_LE(fountain.reach_m, 10 + kUnconfirmedReach * 50 + 1e-9);
  EXPECT_LE(fountain.captures.size(), 14u);           // those within its reach
  EXPECT_NE(sites.site_of("junk250"), "s-fountain");  // 5 km north
  // The walk founded a site every few radii: none is kilometres wide.
  EXPECT_GE(sites.sites().size(), 8000 / 260u);
  for (const Site& s : sites.sites()) EXPECT_LE(s.reach_m, 210 + 1e-9);
  // A capture back at the fountain goes to the fountain.
  EXPECT_EQ(sites.place("back", offset(-5, 0), ""), "s-fountain");
}

TEST(SiteDirectory, TheFootprintOfAModelIsItsGeoRegisteredCameras) {
  Model model;
  for (int i = 0; i < 3; ++i) {
    ModelImage image;
    const GeoFix at = offset(10.0 * i, 0);
    image.geodetic = Geodetic{at.lat, at.lon, 300.0 + i};
    model.images.push_back(image);
  }
  model.images.push_back(ModelImage{});  // no position: not counted
  const Footprint fp = registered_footprint(model);
  EXPECT_EQ(fp.cameras, 3);
  const GeoFix mid = offset(10, 0);
  EXPECT_NEAR(util::great_circle_m(fp.lat, fp.lon, mid.lat, mid.lon), 0, 0.01);
  EXPECT_NEAR(fp.alt, 301, 1e-9);
  EXPECT_NEAR(fp.extent_m, 10, 0.01);
  EXPECT_EQ(registered_footprint(Model{}).cameras, 0);
}

}  // namespace
}  // namespace arscout::engine::service
