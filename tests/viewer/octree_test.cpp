// The level-of-detail octree (point_octree.h) and the viewer's cache of it
// per model version (cloud_octree.h), on the synthetic street.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <memory>
#include <tuple>
#include <vector>

#include "arscout/db/errors.h"
#include "arscout/db/store.h"
#include "arscout/util/error.h"
#include "cloud_octree.h"
#include "point_octree.h"
#include "synthetic_street.h"
#include "test_stores.h"

namespace arscout::viewer {
namespace {

using engine::ColoredPoint;

bool inside(const OctreeBox& box, const ColoredPoint& p) {
  const double xyz[3] = {p.x, p.y, p.z};
  for (int a = 0; a < 3; ++a)
    if (xyz[a] < box.lo[a] - 1e-9 || xyz[a] > box.hi[a] + 1e-9) return false;
  return true;
}

bool contains(const OctreeBox& outer, const OctreeBox& inner) {
  for (int a = 0; a < 3; ++a)
    if (inner.lo[a] < outer.lo[a] || inner.hi[a] > outer.hi[a]) return false;
  return true;
}

TEST(PointOctree, EveryPointOnceInItsNodesBoxWithFinerSamplesBelow) {
  const auto cloud = street_cloud::synthetic_street(120000);
  const OctreeOptions options{4000, 16};
  const std::vector<OctreeNode> nodes = build_point_octree(cloud, options);
  ASSERT_GT(nodes.size(), 8u);
  EXPECT_EQ(nodes[0].name, "r");
  std::vector<int> seen(cloud.size(), 0);
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    const OctreeNode& node = nodes[i];
    for (std::uint32_t p : node.points) {
      ++seen[p];
      EXPECT_TRUE(inside(node.box, cloud[p])) << node.name;
    }
    if (node.children.empty()) {
      EXPECT_EQ(node.spacing, 0) << node.name;
      EXPECT_LE(node.points.size(), options.max_node_points) << node.name;
    } else {
      EXPECT_GT(node.spacing, 0) << node.name;
      // One point per cell of a 16^3 grid (ceil of the cube root of 4000).
      EXPECT_LE(node.points.size(), 16u * 16 * 16) << node.name;
    }
    for (std::size_t c : node.children) {
      ASSERT_GT(c, i) << "a child before its parent";
      EXPECT_EQ(nodes[c].depth, node.depth + 1);
      EXPECT_EQ(nodes[c].name.substr(0, node.name.size()), node.name);
      EXPECT_TRUE(contains(node.box, nodes[c].box)) << nodes[c].name;
      if (!nodes[c].children.empty()) {
        EXPECT_LT(nodes[c].spacing, node.spacing);
      }
    }
  }
  for (std::size_t p = 0; p < cloud.size(); ++p)
    ASSERT_EQ(seen[p], 1) << "point " << p;
  EXPECT_THROW(build_point_octree({}), std::invalid_argument);
}

using PointRecord = std::tuple<float, float, float, int, int, int, int>;

TEST(CloudOctree, HierarchyAndNodeBytesHoldTheCloud) {
  auto cloud = street_cloud::synthetic_street(30000);
  for (size_t i = 0; i < cloud.size(); ++i)
    cloud[i].support = static_cast<uint8_t>(i % 6);
  const CloudOctree octree =
      build_cloud_octree(cloud, "street", 7, "dense", {2000, 16});
  EXPECT_EQ(octree.hierarchy.at("version"), 7);
  EXPECT_EQ(octree.hierarchy.at("cloud"), "dense");
  EXPECT_EQ(octree.hierarchy.at("points"), cloud.size());
  std::vector<PointRecord> read;
  for (const auto& node : octree.hierarchy.at("nodes")) {
    const std::string& bytes = octree.node_bytes.at(node.at("name"));
    const std::size_t n = node.at("points");
    ASSERT_EQ(bytes.size(), n * 16);
    for (std::size_t i = 0; i < n; ++i) {
      float xyz[3];
      std::memcpy(xyz, bytes.data() + i * 12, sizeof xyz);
      const auto* rgb =
          reinterpret_cast<const unsigned char*>(bytes.data() + n * 12 + i * 3);
      const auto support = static_cast<unsigned char>(bytes[n * 15 + i]);
      read.emplace_back(xyz[0], xyz[1], xyz[2], rgb[0], rgb[1], rgb[2],
                        support);
    }
  }
  std::vector<PointRecord> expected;
  for (const ColoredPoint& p : cloud)
    expected.emplace_back(p.x, p.y, p.z, p.r, p.g, p.b, p.support);
  std::sort(read.begin(), read.end());
  std::sort(expected.begin(), expected.end());
  EXPECT_EQ(read, expected);
}

class CloudOctreeCacheTest : public ::testing::Test {
 protected:
  void SetUp() override {
    store_ = db::Store::open(testing::fresh_sqlite_url());
  }
  std::unique_ptr<db::Store> store_;
};

TEST_F(CloudOctreeCacheTest, BuildsOncePerVersionAndFollowsTheModel) {
  CloudOctreeCache cache;
  EXPECT_THROW(cache.current(*store_, "s", Cloud::kDense), util::Error);
  street_cloud::write_street_site(*store_, "s",
                                  street_cloud::synthetic_street(20000));
  const auto first = cache.current(*store_, "s", Cloud::kDense);
  EXPECT_EQ(first->cloud, "dense");
  EXPECT_EQ(first->hierarchy.at("points"), 20000);
  EXPECT_EQ(cache.current(*store_, "s", Cloud::kDense), first);
  EXPECT_EQ(cache.find("s", first->version, "dense"), first);
  EXPECT_EQ(cache.current(*store_, "s", Cloud::kSparse)->hierarchy.at("points"),
            5000);

  street_cloud::write_street_site(*store_, "s",
                                  street_cloud::synthetic_street(10000, 3));
  const auto second = cache.current(*store_, "s", Cloud::kDense);
  EXPECT_GT(second->version, first->version);
  EXPECT_EQ(second->hierarchy.at("points"), 10000);
  // Both fit the default memory bound: the old one is still served.
  EXPECT_EQ(cache.find("s", first->version, "dense"), first);
  EXPECT_EQ(cache.find("s", first->version + 100, "dense"), nullptr);
}

TEST_F(CloudOctreeCacheTest, DropsTheLeastRecentlyUsedBeyondItsBytes) {
  CloudOctreeCache cache(1);  // keeps only the last one
  street_cloud::write_street_site(*store_, "a",
                                  street_cloud::synthetic_street(5000));
  street_cloud::write_street_site(*store_, "b",
                                  street_cloud::synthetic_street(5000, 2));
  const auto a = cache.current(*store_, "a", Cloud::kDense);
  const auto b = cache.current(*store_, "b", Cloud::kDense);
  EXPECT_EQ(cache.find("a", a->version, "dense"), nullptr);
  EXPECT_EQ(cache.find("b", b->version, "dense"), b);
  // What a request holds stays valid after eviction.
  EXPECT_EQ(a->hierarchy.at("points"), 5000);
}

TEST_F(CloudOctreeCacheTest, AMergedSiteServesTheModelOfTheSiteItGrewInto) {
  street_cloud::write_street_site(*store_, "s",
                                  street_cloud::synthetic_street(2000), true);
  const SiteModel model = load_site_model(*store_, "s-before");
  EXPECT_EQ(model.site, "s");
  EXPECT_EQ(model.document.components.size(), 2u);
  EXPECT_EQ(model.document.images.size(), 12u);
  CloudOctreeCache cache;
  EXPECT_EQ(
      cache.current(*store_, "s-before", Cloud::kDense)->hierarchy.at("points"),
      2000);
  // A site never placed is not found, and says so.
  try {
    load_site_model(*store_, "nosuchsite");
    ADD_FAILURE() << "no error for a site that does not exist";
  } catch (const util::Error& e) {
    EXPECT_EQ(e.kind(), util::ErrorKind::kNotFound);
    EXPECT_NE(std::string(e.what()).find("no site nosuchsite"),
              std::string::npos);
  }
}

}  // namespace
}  // namespace arscout::viewer
