// util/compress.h: deflate and inflate round trip, an inflate never grows
// past the size it is given, and the byte shuffle is its own inverse's
// inverse.
#include "arscout/util/compress.h"

#include <gtest/gtest.h>

#include <random>
#include <stdexcept>
#include <string>

namespace arscout::util {
namespace {

std::string noise(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::string s(n, '\0');
  for (char& c : s) c = static_cast<char>(rng());
  return s;
}

TEST(Compress, DeflateRoundTripsAnyBytes) {
  for (const std::string& bytes :
       {std::string(), std::string(1, 'x'), std::string(1 << 20, '\0'),
        noise(100000, 1), std::string(300000, 'a') + noise(1000, 2)}) {
    for (const int level : {1, 9}) {
      const std::string deflated = deflate_bytes(bytes, level);
      EXPECT_EQ(inflate_bytes(deflated, bytes.size()), bytes);
    }
  }
  EXPECT_LT(deflate_bytes(std::string(1 << 20, '\0')).size(), 5000u);
}

TEST(Compress, InflateRefusesOtherSizesAndDamage) {
  const std::string bytes = std::string(50000, 'b') + noise(50000, 3);
  const std::string deflated = deflate_bytes(bytes);
  EXPECT_THROW(inflate_bytes(deflated, bytes.size() - 1), std::runtime_error);
  EXPECT_THROW(inflate_bytes(deflated, bytes.size() + 1), std::runtime_error);
  EXPECT_THROW(
      inflate_bytes(deflated.substr(0, deflated.size() / 2), bytes.size()),
      std::runtime_error);
  EXPECT_THROW(inflate_bytes(deflated + "x", bytes.size()), std::runtime_error);
  std::string damaged = deflated;
  damaged[damaged.size() / 2] ^= 0x21;
  EXPECT_THROW(inflate_bytes(damaged, bytes.size()), std::runtime_error);
  EXPECT_THROW(inflate_bytes(noise(1000, 4), 5000), std::runtime_error);
  // A bomb (64 MiB of zeros deflate to about 64 KB) told a small size
  // allocates only that, and is refused.
  const std::string bomb = deflate_bytes(std::string(64 << 20, '\0'), 9);
  EXPECT_THROW(inflate_bytes(bomb, 1 << 20), std::runtime_error);
}

TEST(Compress, ShuffleGroupsBytesOfEqualSignificance) {
  const std::string bytes = "ABCDabcd0123";  // three numbers of 4 bytes
  EXPECT_EQ(shuffle_bytes(bytes, 4), "Aa0Bb1Cc2Dd3");
  EXPECT_EQ(unshuffle_bytes(shuffle_bytes(bytes, 4), 4), bytes);
  const std::string n = noise(4096, 5);
  for (const std::size_t width : {1u, 2u, 4u, 8u})
    EXPECT_EQ(unshuffle_bytes(shuffle_bytes(n, width), width), n);
  EXPECT_THROW(shuffle_bytes("abc", 2), std::invalid_argument);
  EXPECT_THROW(unshuffle_bytes("abc", 0), std::invalid_argument);
}

}  // namespace
}  // namespace arscout::util
