// The small shared pieces: SHA-256 digests, RFC 3339 times, great-circle
// distances.
#include <gtest/gtest.h>

#include "arscout/util/geodesy.h"
#include "arscout/util/sha256.h"
#include "arscout/util/time.h"

namespace arscout::util {
namespace {

TEST(Sha256, KnownDigestsIncrementallyAndAtOnce) {
  // FIPS 180-2's "abc".
  const std::string abc =
      "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad";
  EXPECT_EQ(sha256_hex("abc"), abc);
  Sha256 h;
  h.update("a");
  h.update("bc");
  EXPECT_EQ(h.hex_digest(), abc);
  EXPECT_TRUE(is_sha256_hex(abc));
  EXPECT_FALSE(is_sha256_hex(abc.substr(1)));
  EXPECT_FALSE(is_sha256_hex("BA" + abc.substr(2)));
  const unsigned char bytes[] = {0x00, 0x0f, 0xa0, 0xff};
  EXPECT_EQ(to_hex(bytes, 4), "000fa0ff");
}

TEST(Time, ParsesRfc3339WithOffsetsAndWritesUtc) {
  EXPECT_EQ(parse_time_utc("1970-01-01T00:00:00Z"), 0);
  EXPECT_EQ(parse_time_utc("2026-11-21T14:05:00.250+01:00"),
            parse_time_utc("2026-11-21T13:05:00Z"));
  EXPECT_EQ(format_time_utc(*parse_time_utc("2026-11-21 13:05:00")),
            "2026-11-21T13:05:00Z");  // no offset: UTC
  for (const char* bad :
       {"2026-02-30T00:00:00Z", "2026-11-21T24:00:00Z", "2026-11-21T13:05:00.Z",
        "2026-11-21T13:05:00+1", "9999-12-31T23:59:59-01:00", "yesterday"})
    EXPECT_FALSE(parse_time_utc(bad)) << bad;
}

TEST(Geodesy, GreatCircleDistances) {
  EXPECT_EQ(great_circle_m(47.07, 15.44, 47.07, 15.44), 0);
  // A degree of latitude on the mean sphere.
  EXPECT_NEAR(great_circle_m(47, 15, 48, 15), 111195.1, 0.1);
  // Graz to Lausanne, about 677 km.
  EXPECT_NEAR(great_circle_m(47.07, 15.44, 46.52, 6.57) / 1000, 677, 15);
}

}  // namespace
}  // namespace arscout::util
