// Site placement: distance, footprints that grow along a walk, hints, and
// ids that come out the same when a capture is placed again.
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
  // The centre is the mean of the fixes.
  const auto site = sites.site(*first);
  ASSERT_TRUE(site);
  const GeoFix mid = offset(10, 5);
  EXPECT_NEAR(util::great_circle_m(site->lat, site->lon, mid.lat, mid.lon), 0,
              0.01);
  EXPECT_EQ(site->captures, (std::vector<std::string>{"a", "b"}));
}

TEST(SiteDirectory, AStreetWalkStaysOneSite) {
  // 29 photos 6 m apart: 170 m of street, as opensfm/lund.
  SiteDirectory sites(50);
  for (int i = 0; i < 29; ++i)
    sites.place("p" + std::to_string(i), offset(6.0 * i, 0), "");
  ASSERT_EQ(sites.sites().size(), 1u);
  EXPECT_GE(sites.sites()[0].extent_m, 84);  // half the walk, at least
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
  EXPECT_NEAR(site->extent_m, sites.site("s-a")->extent_m, 1e-9);
  EXPECT_EQ(reloaded.place("c", offset(30, 0), ""), "s-a");
}

}  // namespace
}  // namespace arscout::engine::service
