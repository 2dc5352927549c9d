// Where photos without a fix go (scout_trails.h): by their scout's photos
// taken within the window, nearest in time; or they wait until one is
// placed.
#include "scout_trails.h"

#include <gtest/gtest.h>

namespace arscout::engine::service {
namespace {

TEST(ScoutTrails, APhotoGoesWhereItsScoutsNearestPhotoInTimeWent) {
  ScoutTrails trails(600);
  EXPECT_FALSE(trails.site_near("alice", 1000));
  trails.placed("alice", 1000, "s-a");
  trails.placed("alice", 2000, "s-b");
  trails.placed("bob", 1500, "s-c");
  EXPECT_EQ(trails.site_near("alice", 1100), "s-a");
  EXPECT_EQ(trails.site_near("alice", 1600), "s-b");  // 400 s from s-b
  EXPECT_EQ(trails.site_near("alice", 2500), "s-b");
  EXPECT_FALSE(trails.site_near("alice", 2601));  // beyond the window
  EXPECT_FALSE(trails.site_near("alice", 399));
  EXPECT_EQ(trails.site_near("bob", 1000), "s-c");  // each scout their own
  EXPECT_FALSE(trails.site_near("carol", 1000));
}

TEST(ScoutTrails, WaitingPhotosAreReleasedByAPhotoWithinTheWindow) {
  ScoutTrails trails(600);
  trails.wait("carol", 1000, "carol.a");
  trails.wait("carol", 1000, "carol.a");  // seen again: kept once
  trails.wait("carol", 5000, "carol.b");
  trails.wait("dave", 1000, "dave.a");
  EXPECT_TRUE(trails.release("carol", 3000).empty());
  EXPECT_EQ(trails.release("carol", 1500), std::vector<std::string>{"carol.a"});
  EXPECT_TRUE(trails.release("carol", 1500).empty());  // released once
  EXPECT_EQ(trails.release("carol", 4400), std::vector<std::string>{"carol.b"});
  EXPECT_EQ(trails.release("dave", 400), std::vector<std::string>{"dave.a"});
}

}  // namespace
}  // namespace arscout::engine::service
