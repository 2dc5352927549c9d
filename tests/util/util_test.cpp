// The shared small pieces: the Prometheus histogram and log values.
#include <gtest/gtest.h>

#include "arscout/util/histogram.h"
#include "arscout/util/log_value.h"

namespace arscout::util {
namespace {

TEST(Histogram, RendersCumulativeBucketsSumAndCount) {
  Histogram h;
  h.observe(0.002);
  h.observe(0.3);
  h.observe(100);  // beyond every bucket: only +Inf counts it
  const std::string text = h.render("x_seconds", "phase=\"a\"");
  EXPECT_NE(text.find("x_seconds_bucket{phase=\"a\",le=\"0.001\"} 0\n"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("x_seconds_bucket{phase=\"a\",le=\"0.0025\"} 1\n"),
            std::string::npos);
  EXPECT_NE(text.find("x_seconds_bucket{phase=\"a\",le=\"0.5\"} 2\n"),
            std::string::npos);
  EXPECT_NE(text.find("x_seconds_bucket{phase=\"a\",le=\"60\"} 2\n"),
            std::string::npos);
  EXPECT_NE(text.find("x_seconds_bucket{phase=\"a\",le=\"+Inf\"} 3\n"),
            std::string::npos);
  EXPECT_NE(text.find("x_seconds_sum{phase=\"a\"} 100.302\n"),
            std::string::npos);
  EXPECT_NE(text.find("x_seconds_count{phase=\"a\"} 3\n"), std::string::npos);
  EXPECT_EQ(h.count(), 3u);
  // Without labels.
  EXPECT_NE(
      Histogram().render("y", "").find("y_bucket{le=\"+Inf\"} 0\ny_sum 0\n"
                                       "y_count 0\n"),
      std::string::npos);
}

TEST(LogValue, StaysOneQuotedRecord) {
  EXPECT_EQ(quoted_log_value("plain"), "\"plain\"");
  EXPECT_EQ(quoted_log_value("a \"b\" \\c"), "\"a \\\"b\\\" \\\\c\"");
  EXPECT_EQ(quoted_log_value("two\nlines\r"), "\"two lines \"");
  EXPECT_EQ(quoted_log_value("abcdef", 3), "\"abc...\"");
}

}  // namespace
}  // namespace arscout::util
