#include "arscout/db/path.h"

#include <gtest/gtest.h>

#include "arscout/db/errors.h"

namespace arscout::db {
namespace {

TEST(PathTest, AcceptsWellFormedPaths) {
  for (const char* p : {"/a", "/sites/s-3/model", "/x.y_z-1/B2", "/a/..b/c."})
    EXPECT_NO_THROW(validate_path(p)) << p;
}

TEST(PathTest, RejectsMalformedPathsNamingTheRule) {
  struct Case {
    std::string path;
    std::string says;
  };
  std::vector<Case> cases = {
      {"", "empty"},
      {"a/b", "start with '/'"},
      {"/", "root"},
      {"/a/", "ends with '/'"},
      {"/a//b", "empty"},
      {"/a/./b", "'.'"},
      {"/a/../b", "'..'"},
      {"/a b", "' '"},
      {"/caf\xc3\xa9", "byte"},
      {"/a/*", "'*'"},
      {"/" + std::string(200, 'a'), "longer than 128"},
      {std::string(600, '/'), "longer than 512"},
  };
  std::string deep;
  for (int i = 0; i < 17; ++i) deep += "/a";
  cases.push_back({deep, "more than 16"});
  for (const auto& c : cases) {
    try {
      validate_path(c.path);
      ADD_FAILURE() << "accepted " << c.path;
    } catch (const StoreError& e) {
      EXPECT_EQ(e.code(), ErrorCode::kInvalidPath);
      EXPECT_NE(std::string(e.what()).find(c.says), std::string::npos)
          << e.what();
    }
  }
}

TEST(PathTest, RootIsReadableButNotWritable) {
  EXPECT_NO_THROW(validate_path("/", /*root_ok=*/true));
  EXPECT_THROW(validate_path("/"), StoreError);
}

TEST(PathTest, SplitsAndNames) {
  EXPECT_EQ(path_depth("/"), 0u);
  EXPECT_EQ(path_depth("/a/b/c"), 3u);
  EXPECT_EQ(parent_path("/a/b/c"), "/a/b");
  EXPECT_EQ(parent_path("/a"), "/");
  EXPECT_EQ(leaf_name("/a/b/c"), "c");
}

TEST(PatternTest, StarMatchesExactlyOneSegment) {
  EXPECT_TRUE(matches_pattern("/captures/*", "/captures/c1"));
  EXPECT_FALSE(matches_pattern("/captures/*", "/captures"));
  EXPECT_FALSE(matches_pattern("/captures/*", "/captures/c1/thumb"));
  EXPECT_FALSE(matches_pattern("/captures/*", "/capturesX/c1"));
  EXPECT_TRUE(matches_pattern("/sites/*/model", "/sites/s-3/model"));
  EXPECT_FALSE(matches_pattern("/sites/*/model", "/sites/s-3/models"));
}

TEST(PatternTest, DoubleStarMatchesAnyDepthIncludingNone) {
  EXPECT_TRUE(matches_pattern("/sites/**", "/sites"));
  EXPECT_TRUE(matches_pattern("/sites/**", "/sites/a/b/c"));
  EXPECT_FALSE(matches_pattern("/sites/**", "/sitesX"));
  EXPECT_TRUE(matches_pattern("/**", "/anything/at/all"));
  EXPECT_TRUE(matches_pattern("/a/b", "/a/b"));
  EXPECT_FALSE(matches_pattern("/a/b", "/a/b/c"));
}

TEST(PatternTest, ValidatesPatterns) {
  EXPECT_NO_THROW(validate_pattern("/**"));
  EXPECT_NO_THROW(validate_pattern("/sites/*/model"));
  EXPECT_THROW(validate_pattern("/**/x"), StoreError);
  EXPECT_THROW(validate_pattern("/a*"), StoreError);
  EXPECT_THROW(validate_pattern("/../x"), StoreError);
}

TEST(PatternTest, LiteralPrefixNarrowsEveryMatch) {
  EXPECT_EQ(pattern_literal_prefix("/sites/*/model"), "/sites");
  EXPECT_EQ(pattern_literal_prefix("/captures/*"), "/captures");
  EXPECT_EQ(pattern_literal_prefix("/**"), "");
  EXPECT_EQ(pattern_literal_prefix("/a/b"), "/a/b");
}

}  // namespace
}  // namespace arscout::db
