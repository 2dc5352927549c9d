// Little-endian bytes (arscout/util/bytes.h): the exact bytes numbers
// become, round trips, and how a reader refuses too few bytes.
#include "arscout/util/bytes.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>

namespace arscout::util {
namespace {

TEST(ByteWriter, WritesNumbersLeastSignificantByteFirst) {
  ByteWriter w;
  w.put<uint32_t>(0x04030201u);
  w.put<int16_t>(-2);
  w.put<uint8_t>(0xAB);
  w.put<double>(1.0);  // IEEE 754: 0x3FF0000000000000
  EXPECT_EQ(w.bytes(), std::string("\x01\x02\x03\x04\xFE\xFF\xAB"
                                   "\x00\x00\x00\x00\x00\x00\xF0\x3F",
                                   15));
}

TEST(ByteWriter, AppendsRawBytesAndPatchesFieldsInPlace) {
  ByteWriter w;
  w.append("MAGIC");
  w.put<uint64_t>(0);  // a size known only at the end
  w.append("xy", 2);
  w.put_at<uint64_t>(5, w.size());
  EXPECT_EQ(w.bytes(), std::string("MAGIC\x0F\0\0\0\0\0\0\0xy", 15));
  EXPECT_THROW(w.put_at<uint32_t>(12, 1), std::out_of_range);
  const std::string taken = w.take();
  EXPECT_EQ(taken.size(), 15u);
  EXPECT_EQ(w.size(), 0u);
}

TEST(ByteReader, ReadsBackWhatTheWriterWrote) {
  ByteWriter w;
  w.put<int64_t>(std::numeric_limits<int64_t>::min());
  w.put<float>(-0.5f);
  w.put<double>(std::numeric_limits<double>::denorm_min());
  w.put<int32_t>(-7);
  w.append("tail");
  const std::string bytes = w.take();

  ByteReader r(bytes, "prefix: ");
  EXPECT_EQ(r.size(), bytes.size());
  EXPECT_EQ(r.get<int64_t>(), std::numeric_limits<int64_t>::min());
  EXPECT_EQ(r.get<float>(), -0.5f);
  EXPECT_EQ(r.get<double>(), std::numeric_limits<double>::denorm_min());
  EXPECT_EQ(r.get<int32_t>(), -7);
  EXPECT_EQ(r.left(), 4u);
  EXPECT_FALSE(r.done());
  EXPECT_EQ(r.take(4), "tail");
  EXPECT_TRUE(r.done());
}

TEST(ByteReader, FailuresCarryTheCallersPrefix) {
  const std::string bytes("\x01\x02\x03", 3);
  ByteReader r(bytes, "not a thing: ");
  try {
    r.get<uint32_t>();
    ADD_FAILURE() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "not a thing: truncated");
  }
  // A refused read consumes nothing.
  EXPECT_EQ(r.left(), 3u);
  EXPECT_EQ(r.get<uint16_t>(), 0x0201);
  EXPECT_THROW(r.take(2), std::runtime_error);
  try {
    r.fail("bad field");
    ADD_FAILURE() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "not a thing: bad field");
  }
}

}  // namespace
}  // namespace arscout::util
