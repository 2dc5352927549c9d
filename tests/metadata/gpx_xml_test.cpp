// The GPX reader as an XML reader of untrusted files (read_gpx, gps.h):
// entity attacks and oversized files refused with a clear error, XML that
// real devices write accepted, and a track cut off by a logger that lost
// power keeping its complete points.
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include "arscout/metadata/gps.h"
#include "test_stores.h"

namespace arscout::metadata {
namespace {

namespace fs = std::filesystem;

std::string write_gpx(const std::string& name, const std::string& content) {
  static const std::string dir = testing::make_temp_dir("gpx-xml");
  const std::string path = dir + "/" + name;
  std::ofstream(path, std::ios::binary) << content;
  return path;
}

// The message of the std::runtime_error read_gpx throws ("" if none).
std::string error_of(const std::string& path) {
  try {
    read_gpx(path);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

const char* kPoints = R"(<trk><trkseg>
<trkpt lat="47.07" lon="15.44"><time>2026-11-21T13:05:00Z</time></trkpt>
<trkpt lat="47.08" lon="15.45"><time>2026-11-21T13:05:10Z</time></trkpt>
</trkseg></trk>)";

TEST(GpxXml, EntityDeclarationsAreRefused) {
  const std::string laughs =
      "<?xml version=\"1.0\"?>\n"
      "<!DOCTYPE gpx [\n"
      "  <!ENTITY lol \"lol\">\n"
      "  <!ENTITY lol2 \"&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;\">\n"
      "  <!ENTITY lol3 \"&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;\">\n"
      "]>\n<gpx><trk><name>&lol3;</name></trk>" +
      std::string(kPoints) + "</gpx>\n";
  const std::string error = error_of(write_gpx("laughs.gpx", laughs));
  EXPECT_NE(error.find("line 3: the DOCTYPE declares entity 'lol'"),
            std::string::npos)
      << error;

  const std::string external =
      "<!DOCTYPE gpx [<!ENTITY x SYSTEM \"file:///etc/passwd\">]>\n"
      "<gpx><trk><name>&x;</name></trk></gpx>\n";
  EXPECT_NE(
      error_of(write_gpx("external.gpx", external)).find("declares entity 'x'"),
      std::string::npos);

  const std::string parameter =
      "<!DOCTYPE gpx [<!ENTITY % p SYSTEM \"http://example.com/x.dtd\"> %p;]>"
      "\n<gpx/>\n";
  EXPECT_NE(error_of(write_gpx("parameter.gpx", parameter))
                .find("declares entity 'p'"),
            std::string::npos);

  // An entity nobody declared is no entity either.
  const std::string error2 = error_of(
      write_gpx("undeclared.gpx", "<gpx><trk><name>&x;</name></trk></gpx>\n"));
  EXPECT_NE(error2.find("not well-formed XML"), std::string::npos) << error2;
}

TEST(GpxXml, OversizedFilesAreRefusedUnread) {
  const std::string path = write_gpx("huge.gpx", "<gpx>");
  fs::resize_file(path, (256u << 20) + 1);  // sparse: nothing is written
  const std::string error = error_of(path);
  EXPECT_NE(error.find("more than a GPX track's"), std::string::npos) << error;
  fs::remove(path);
}

TEST(GpxXml, AcceptsWhatDevicesWrite) {
  // A DOCTYPE without entities, CDATA, character references, CRLF, an
  // encoding expat does not know.
  const std::string gpx =
      "<?xml version=\"1.0\" encoding=\"windows-1252\"?>\r\n"
      "<!DOCTYPE gpx>\r\n"
      "<gpx><trk><name>Caf\xE9 walk</name><trkseg>\r\n"
      "<trkpt lat=\"&#52;7.07\" lon=\"15.44\"><time><![CDATA["
      "2026-11-21T13:05:00Z]]></time></trkpt>\r\n"
      "</trkseg></trk></gpx>\r\n";
  const auto track = read_gpx(write_gpx("devices.gpx", gpx));
  ASSERT_EQ(track.size(), 1u);
  EXPECT_DOUBLE_EQ(track[0].fix.lat, 47.07);
  EXPECT_EQ(track[0].fix.time, "2026-11-21T13:05:00Z");
}

TEST(GpxXml, ATrackCutOffKeepsItsCompletePoints) {
  const std::string whole = "<gpx>" + std::string(kPoints) + "</gpx>\n";
  const std::string cut = whole.substr(0, whole.find("</trkseg>"));
  const auto track = read_gpx(write_gpx("cut.gpx", cut));
  EXPECT_EQ(track.size(), 2u);

  const std::string in_point = whole.substr(0, whole.rfind("</time>"));
  EXPECT_NE(error_of(write_gpx("in_point.gpx", in_point))
                .find("unterminated <trkpt>"),
            std::string::npos);
}

TEST(GpxXml, MalformedXmlNamesTheLine) {
  const std::string junk = "<gpx>" + std::string(kPoints) + "</gpx>\n<gpx/>";
  const std::string error = error_of(write_gpx("junk.gpx", junk));
  EXPECT_NE(error.find("line 5: not well-formed XML"), std::string::npos)
      << error;
  const std::string crossed = "<gpx><trk>\n</gpx></trk>";
  const std::string error2 = error_of(write_gpx("crossed.gpx", crossed));
  EXPECT_NE(error2.find("line 2: unexpected </gpx>, expected </trk>"),
            std::string::npos)
      << error2;
}

}  // namespace
}  // namespace arscout::metadata
