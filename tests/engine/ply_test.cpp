// PLY point clouds: what encode_ply writes reads back to the bit, files from
// other tools (ascii, doubles, extra properties, other elements) read, and
// every malformed or cut-short input ends in std::runtime_error, never a
// crash or a read outside the buffer (run under ARSCOUT_SANITIZE to see).
#include "arscout/engine/ply.h"

#include <unistd.h>

#include <array>
#include <bit>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

namespace arscout::engine {
namespace {

namespace fs = std::filesystem;

constexpr char kHeader[] =
    "ply\n"
    "format binary_little_endian 1.0\n"
    "comment written by arscout\n"
    "element vertex 2\n"
    "property float x\n"
    "property float y\n"
    "property float z\n"
    "property uchar red\n"
    "property uchar green\n"
    "property uchar blue\n"
    "end_header\n";

// Bit patterns, so that -0.0 differs from 0.0 and NaNs compare.
uint32_t bits(float value) { return std::bit_cast<uint32_t>(value); }

void expect_identical(const std::vector<ColoredPoint>& a,
                      const std::vector<ColoredPoint>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    SCOPED_TRACE("point " + std::to_string(i));
    EXPECT_EQ(bits(a[i].x), bits(b[i].x));
    EXPECT_EQ(bits(a[i].y), bits(b[i].y));
    EXPECT_EQ(bits(a[i].z), bits(b[i].z));
    EXPECT_EQ(a[i].r, b[i].r);
    EXPECT_EQ(a[i].g, b[i].g);
    EXPECT_EQ(a[i].b, b[i].b);
    EXPECT_EQ(bits(a[i].nx), bits(b[i].nx));
    EXPECT_EQ(bits(a[i].ny), bits(b[i].ny));
    EXPECT_EQ(bits(a[i].nz), bits(b[i].nz));
    EXPECT_EQ(a[i].support, b[i].support);
    EXPECT_EQ(a[i].score, b[i].score);
  }
}

std::vector<ColoredPoint> random_points(size_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> coordinate(-1e4f, 1e4f);
  std::uniform_int_distribution<int> colour(0, 255);
  std::vector<ColoredPoint> points(n);
  for (ColoredPoint& p : points) {
    p = {coordinate(rng),
         coordinate(rng),
         coordinate(rng),
         static_cast<uint8_t>(colour(rng)),
         static_cast<uint8_t>(colour(rng)),
         static_cast<uint8_t>(colour(rng))};
  }
  return points;
}

std::vector<ColoredPoint> extreme_points() {
  using L = std::numeric_limits<float>;
  const float values[] = {L::max(),        -L::max(),        L::min(),
                          L::denorm_min(), -L::denorm_min(), 0.0f,
                          -0.0f,           L::infinity(),    -L::infinity(),
                          L::quiet_NaN(),  L::epsilon(),     1.0f};
  std::vector<ColoredPoint> points;
  for (float v : values) {
    points.push_back({v, -v, v * 0.5f, 0, 255, 128});
  }
  return points;
}

// Little-endian bytes of a value, as a binary PLY body holds it.
template <class T>
void append(std::string& out, T value) {
  const auto raw = std::bit_cast<std::array<char, sizeof(T)>>(value);
  if constexpr (std::endian::native == std::endian::little) {
    out.append(raw.begin(), raw.end());
  } else {
    out.append(raw.rbegin(), raw.rend());
  }
}

// A binary file as other tools write it: normals, alpha and a double
// between the coordinates and colours, an element before the vertices and
// a face element after them.
std::string binary_with_extras(const std::vector<ColoredPoint>& points) {
  std::string bytes =
      "ply\r\n"
      "format binary_little_endian 1.0\r\n"
      "comment from elsewhere\r\n"
      "obj_info scanner 7\r\n"
      "element camera 1\r\n"
      "property list uchar int32 ids\r\n"
      "property short tag\r\n"
      "element vertex " +
      std::to_string(points.size()) +
      "\r\n"
      "property float32 x\r\n"
      "property float32 y\r\n"
      "property float32 z\r\n"
      "property float nx\r\n"
      "property float ny\r\n"
      "property float nz\r\n"
      "property double quality\r\n"
      "property uint8 red\r\n"
      "property uint8 green\r\n"
      "property uint8 blue\r\n"
      "property uchar alpha\r\n"
      "property int label\r\n"
      "element face 1\r\n"
      "property list uchar int vertex_indices\r\n"
      "end_header\r\n";
  append<uint8_t>(bytes, 2);  // camera: ids = {7, 8}, tag = -3
  append<int32_t>(bytes, 7);
  append<int32_t>(bytes, 8);
  append<int16_t>(bytes, -3);
  for (const ColoredPoint& p : points) {
    for (float v : {p.x, p.y, p.z, 0.0f, 0.0f, 1.0f}) append(bytes, v);
    append(bytes, 0.75);
    for (uint8_t v : {p.r, p.g, p.b, uint8_t{255}}) append(bytes, v);
    append<int32_t>(bytes, -12345);
  }
  append<uint8_t>(bytes, 3);  // face 0 1 2
  for (int32_t v : {0, 1, 2}) append(bytes, v);
  return bytes;
}

size_t body_offset(const std::string& bytes) {
  return bytes.find('\n', bytes.find("end_header")) + 1;
}

TEST(PlyTest, RoundTripIsBitExact) {
  std::vector<ColoredPoint> points = random_points(1000, 7);
  for (const ColoredPoint& p : extreme_points()) points.push_back(p);
  expect_identical(decode_ply(encode_ply(points)), points);
}

TEST(PlyTest, EmptyCloudRoundTrips) {
  const std::string bytes = encode_ply({});
  EXPECT_NE(bytes.find("element vertex 0\n"), std::string::npos);
  EXPECT_TRUE(decode_ply(bytes).empty());
}

TEST(PlyTest, HeaderAndBodyBytesAreExact) {
  const std::string bytes =
      encode_ply({{1.0f, -2.0f, 0.5f, 1, 2, 3}, {0, 0, 0, 250, 251, 252}});
  const std::string header = kHeader;
  ASSERT_EQ(bytes.size(), header.size() + 2 * 15);
  EXPECT_EQ(bytes.substr(0, header.size()), header);
  // 1.0f = 0x3f800000, -2.0f = 0xc0000000, 0.5f = 0x3f000000, low byte first.
  const std::string first_vertex(
      "\x00\x00\x80\x3f\x00\x00\x00\xc0"
      "\x00\x00\x00\x3f\x01\x02\x03",
      15);
  EXPECT_EQ(bytes.substr(header.size(), 15), first_vertex);
}

TEST(PlyTest, CommentCanBeChosenButNotBreakTheHeader) {
  const std::string bytes = encode_ply({}, "world frame ENU");
  EXPECT_NE(bytes.find("\ncomment world frame ENU\n"), std::string::npos);
  EXPECT_THROW(encode_ply({}, "two\nlines"), std::invalid_argument);
}

TEST(PlyTest, ReadsAsciiWithDoublesAndExtraProperties) {
  const std::string text =
      "ply\n"
      "format ascii 1.0\n"
      "comment made by hand\n"
      "element vertex 3\n"
      "property double x\n"
      "property float64 y\n"
      "property double z\n"
      "property float nx\n"
      "property float ny\n"
      "property float nz\n"
      "property uchar red\n"
      "property uchar green\n"
      "property uchar blue\n"
      "property uchar alpha\n"
      "property int label\n"
      "element face 1\n"
      "property list uchar int vertex_indices\n"
      "end_header\n"
      "0.1 -2.5 1e3 0 0 1 10 20 30 255 -7\n"
      "+4 5.25 -6.125e-2 0.5 0.5 0.5 0 0 0 0 0\n"
      "  1e300\t-1e300 0\n 1 2 3 255 255 255 9 1\n"
      "3 0 1 2\n";
  const std::vector<ColoredPoint> points = decode_ply(text);
  using L = std::numeric_limits<float>;
  expect_identical(
      points, {{0.1f, -2.5f, 1000.0f, 10, 20, 30, 0, 0, 1},
               {4.0f, 5.25f, -0.06125f, 0, 0, 0, 0.5f, 0.5f, 0.5f},
               {L::infinity(), -L::infinity(), 0, 255, 255, 255, 1, 2, 3}});
}

TEST(PlyTest, ReadsAsciiWithoutColours) {
  const std::string text =
      "ply\nformat ascii 1.0\nelement vertex 1\nproperty float z\n"
      "property float y\nproperty float x\nend_header\n1 2 3\n";
  expect_identical(decode_ply(text), {{3, 2, 1, 0, 0, 0}});
}

TEST(PlyTest, ReadsBinaryWithExtraPropertiesAndElements) {
  std::vector<ColoredPoint> points = random_points(20, 11);
  for (const ColoredPoint& p : extreme_points()) points.push_back(p);
  std::vector<ColoredPoint> expected = points;
  for (ColoredPoint& p : expected) p.nz = 1;  // binary_with_extras' normal
  expect_identical(decode_ply(binary_with_extras(points)), expected);
}

// Fused dense points carry a normal, a support and a score: the 29-byte
// layout.
TEST(PlyTest, FusedPointsRoundTripWithNormalSupportAndScore) {
  std::vector<ColoredPoint> points = random_points(200, 5);
  for (size_t i = 0; i < points.size(); ++i) {
    points[i].nx = 0.6f, points[i].ny = -0.8f, points[i].nz = 0;
    points[i].support = static_cast<uint8_t>(i % 7);
    points[i].score = static_cast<uint8_t>(i % 256);
  }
  const std::string bytes = encode_ply(points);
  const std::string fields =
      "property uchar blue\nproperty float nx\nproperty float ny\n"
      "property float nz\nproperty uchar support\nproperty uchar score\n"
      "end_header\n";
  EXPECT_NE(bytes.find(fields), std::string::npos);
  EXPECT_EQ(bytes.size() - body_offset(bytes), points.size() * 29);
  expect_identical(decode_ply(bytes), points);
  // A cloud without supports keeps the 15-byte layout.
  for (ColoredPoint& p : points) p.support = p.score = 0;
  const std::string plain = encode_ply(points);
  EXPECT_EQ(plain.find("support"), std::string::npos);
  EXPECT_EQ(plain.size() - body_offset(plain), points.size() * 15);
}

TEST(PlyTest, SupportAndScoreOfAnyIntegerTypeAreClampedOthersRefused) {
  for (const std::string name : {"support", "score"}) {
    const std::string head =
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
        "property float y\nproperty float z\nproperty ";
    const std::string body =
        " " + name + "\nend_header\n0 0 0 -4\n0 0 0 7\n0 0 0 300\n";
    const auto points = decode_ply(head + "int" + body);
    ASSERT_EQ(points.size(), 3u);
    auto value = [&](const ColoredPoint& p) {
      return name == "support" ? p.support : p.score;
    };
    EXPECT_EQ(value(points[0]), 0) << name;
    EXPECT_EQ(value(points[1]), 7) << name;
    EXPECT_EQ(value(points[2]), 255) << name;
    EXPECT_THROW(decode_ply(head + "float" + body), std::runtime_error);
  }
}

TEST(PlyTest, ReadsDoubleCoordinatesInBinary) {
  std::string bytes =
      "ply\nformat binary_little_endian 1.0\nelement vertex 2\n"
      "property double x\nproperty double y\nproperty double z\n"
      "end_header\n";
  for (double v : {0.1, 2.0, -3.5, 1e300, -1e-300, 65504.0}) append(bytes, v);
  expect_identical(decode_ply(bytes), {{0.1f, 2.0f, -3.5f, 0, 0, 0},
                                       {std::numeric_limits<float>::infinity(),
                                        -0.0f, 65504.0f, 0, 0, 0}});
}

TEST(PlyTest, TruncatedBinaryBodiesThrow) {
  const std::vector<ColoredPoint> points = random_points(4, 3);
  // Each file and how many bytes follow its vertices (the face element,
  // which is ignored, so cutting it short is harmless).
  const std::pair<std::string, size_t> files[] = {
      {encode_ply(points), 0}, {binary_with_extras(points), 1 + 3 * 4}};
  for (const auto& [bytes, trailing] : files) {
    const size_t vertices_end = bytes.size() - trailing;
    for (size_t length = body_offset(bytes); length < vertices_end; ++length) {
      SCOPED_TRACE("length " + std::to_string(length));
      EXPECT_THROW(decode_ply(bytes.substr(0, length)), std::runtime_error);
    }
    for (size_t length = vertices_end; length <= bytes.size(); ++length) {
      EXPECT_EQ(decode_ply(bytes.substr(0, length)).size(), 4u);
    }
  }
}

TEST(PlyTest, TruncatedAsciiBodiesThrowOrReadWhatIsThere) {
  const std::string text =
      "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\n"
      "property float y\nproperty float z\nproperty uchar red\n"
      "end_header\n10 20 30 40\n50 60 70 80\n";
  for (size_t length = body_offset(text); length < text.size(); ++length) {
    SCOPED_TRACE("length " + std::to_string(length));
    // Cutting inside the last number leaves a shorter, valid number.
    const bool cut_in_last_number = length >= text.size() - 2;
    if (cut_in_last_number) {
      EXPECT_EQ(decode_ply(text.substr(0, length)).size(), 2u);
    } else {
      EXPECT_THROW(decode_ply(text.substr(0, length)), std::runtime_error);
    }
  }
}

// Each malformed file must fail with a message naming the problem.
void expect_error(const std::string& bytes, const std::string& fragment) {
  SCOPED_TRACE(bytes);
  try {
    decode_ply(bytes);
    ADD_FAILURE() << "no error, expected one mentioning '" << fragment << "'";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos)
        << e.what();
  }
}

const std::string kXyz =
    "property float x\nproperty float y\nproperty float z\n";

TEST(PlyTest, CorruptHeadersThrow) {
  const std::string binary = "ply\nformat binary_little_endian 1.0\n";
  const std::string ascii = "ply\nformat ascii 1.0\n";
  expect_error("", "magic");
  expect_error("PLY\n", "magic");
  expect_error("plyx\nformat ascii 1.0\nend_header\n", "magic");
  expect_error(binary + "element vertex 0\n" + kXyz, "end_header");
  expect_error(binary + "element vertex 0\n" + kXyz + "end_header",
               "end_header");
  expect_error("ply\nformat binary_big_endian 1.0\nelement vertex 0\n" + kXyz +
                   "end_header\n",
               "unsupported");
  expect_error("ply\nformat utf8 1.0\nend_header\n", "unknown format");
  expect_error("ply\nformat ascii 2.0\nend_header\n", "version");
  expect_error("ply\nformat ascii\nend_header\n", "format line");
  expect_error("ply\nelement vertex 0\n" + kXyz + "end_header\n", "format");
  expect_error(binary + "element vertex\n" + kXyz + "end_header\n", "count");
  expect_error(binary + "element vertex 1 2\n" + kXyz + "end_header\n",
               "malformed element line");
  expect_error(binary + "element vertex -1\n" + kXyz + "end_header\n", "count");
  expect_error(binary + "element vertex 1x\n" + kXyz + "end_header\n", "count");
  expect_error(binary + "element vertex 99999999999999999999999\n" + kXyz +
                   "end_header\n",
               "count");
  expect_error(binary + "element vertex 18446744073709551615\n" + kXyz +
                   "end_header\n" + std::string(150, '\0'),
               "truncated");
  expect_error(ascii + "element vertex 1000000\n" + kXyz + "end_header\n1 2 3",
               "truncated");
  expect_error(binary + "element face 0\n", "end_header");
  expect_error(binary + "element face 0\nend_header\n", "no vertex");
  expect_error(binary + "element vertex 0\n" + kXyz +
                   "property list uchar int idx\nend_header\n",
               "list");
  expect_error(binary +
                   "element vertex 0\nproperty float x\n"
                   "property float y\nend_header\n",
               "lacks x, y or z");
  expect_error(
      binary + "element vertex 0\n" + kXyz + "property float red\nend_header\n",
      "uchar");
  expect_error(
      binary + "element vertex 0\n" + kXyz + "property float x\nend_header\n",
      "twice");
  expect_error(binary + "element vertex 0\n" + kXyz +
                   "property float128 w\nend_header\n",
               "unknown property type");
  expect_error(binary + "property float x\nelement vertex 0\nend_header\n",
               "before any element");
  expect_error(binary + "element vertex 0\n" + kXyz + "element vertex 0\n" +
                   kXyz + "end_header\n",
               "twice");
  expect_error(binary + "element vertex 0\n" + kXyz + "banana\nend_header\n",
               "unknown header line");
  expect_error(binary + "element vertex 0\n" + kXyz +
                   "property list float int idx\nend_header\n",
               "list count");
}

TEST(PlyTest, MalformedAsciiValuesThrow) {
  const std::string header = "ply\nformat ascii 1.0\nelement vertex 1\n" +
                             kXyz + "property uchar red\nend_header\n";
  expect_error(header + "1 2 three 4\n", "not a number");
  expect_error(header + "1 2 0x3 4\n", "not a number");
  expect_error(header + "1 2 3 256\n", "0..255");
  expect_error(header + "1 2 3 -1\n", "0..255");
  expect_error(header + "1 2 3 4.5\n", "0..255");
  expect_error(header + "1 2 3\n", "truncated");
}

TEST(PlyTest, ElementsBeforeVerticesAreCheckedToo) {
  const std::string head =
      "ply\nformat binary_little_endian 1.0\nelement camera 1\n"
      "property list uint int values\nelement vertex 0\n" +
      kXyz + "end_header\n";
  std::string claims_too_many = head;
  append<uint32_t>(claims_too_many, 0xffffffffu);
  expect_error(claims_too_many, "truncated");
  std::string ascii_negative =
      "ply\nformat ascii 1.0\nelement camera 1\n"
      "property list uchar int values\nelement vertex 0\n" +
      kXyz + "end_header\n-2 1 1\n";
  expect_error(ascii_negative, "list size");
}

// Random damage anywhere in a valid file must never crash; with the
// sanitizers on this is a small fuzzer.
TEST(PlyTest, RandomlyDamagedFilesNeverCrash) {
  const std::string original = binary_with_extras(random_points(5, 5));
  std::mt19937 rng(1);
  std::uniform_int_distribution<size_t> where(0, original.size() - 1);
  std::uniform_int_distribution<int> byte(0, 255);
  int rejected = 0;
  for (int round = 0; round < 3000; ++round) {
    std::string bytes = original;
    for (int k = 0; k < 1 + round % 4; ++k) {
      bytes[where(rng)] = static_cast<char>(byte(rng));
    }
    if (round % 3 == 0) bytes.resize(where(rng));
    try {
      decode_ply(bytes);
    } catch (const std::runtime_error&) {
      ++rejected;
    }
  }
  EXPECT_GT(rejected, 0);
}

class PlyFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    // Per process and test: other test runs may share the temp directory.
    dir_ = fs::temp_directory_path() /
           ("arscout_ply_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::vector<std::string> entries() const {
    std::vector<std::string> names;
    for (const auto& entry : fs::directory_iterator(dir_)) {
      names.push_back(entry.path().filename().string());
    }
    return names;
  }

  fs::path dir_;
};

TEST_F(PlyFileTest, WriteLeavesOnlyTheFileAndReadsBack) {
  const std::string path = (dir_ / "cloud.ply").string();
  const std::vector<ColoredPoint> first = random_points(100, 1);
  write_ply(path, first);
  EXPECT_EQ(entries(), std::vector<std::string>{"cloud.ply"});
  expect_identical(read_ply(path), first);

  const std::vector<ColoredPoint> second = random_points(3, 2);
  write_ply(path, second);  // replaces the old file
  EXPECT_EQ(entries(), std::vector<std::string>{"cloud.ply"});
  expect_identical(read_ply(path), second);

  std::ifstream in(path, std::ios::binary);
  const std::string bytes{std::istreambuf_iterator<char>(in), {}};
  EXPECT_EQ(bytes, encode_ply(second));
}

TEST_F(PlyFileTest, WriteFailureNamesThePathAndLeavesNothing) {
  const std::string path = (dir_ / "missing" / "cloud.ply").string();
  try {
    write_ply(path, random_points(3, 1));
    ADD_FAILURE() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
  // Renaming onto a directory fails after the temporary file was written.
  fs::create_directories(dir_ / "taken.ply");
  EXPECT_THROW(write_ply((dir_ / "taken.ply").string(), random_points(3, 1)),
               std::runtime_error);
  EXPECT_EQ(entries(), std::vector<std::string>{"taken.ply"});
}

TEST_F(PlyFileTest, ReadErrorsNameThePath) {
  const std::string missing = (dir_ / "none.ply").string();
  const std::string broken = (dir_ / "broken.ply").string();
  std::ofstream(broken) << "ply\nformat ascii 1.0\n";
  for (const std::string& path : {missing, broken}) {
    try {
      read_ply(path);
      ADD_FAILURE() << "no error for " << path;
    } catch (const std::runtime_error& e) {
      EXPECT_EQ(std::string(e.what()).rfind(path + ": ", 0), 0u) << e.what();
    }
  }
}

// Interoperability: the Point Cloud Library's converter (Debian's
// pcl-tools, installed by deploy/install-deps.sh) reads what write_ply
// writes, every coordinate and colour.
TEST(PlyInterop, PclReadsWhatWeWrite) {
  const char* tool = "/usr/bin/pcl_ply2pcd";
  if (!fs::exists(tool)) {
    const char* ci = std::getenv("CI");
    if (ci && std::string(ci) == "true")
      FAIL() << tool << " missing: deploy/install-deps.sh installs pcl-tools";
    GTEST_SKIP() << tool << " missing (Debian package pcl-tools)";
  }
  std::mt19937 rng(12);
  std::uniform_int_distribution<int> grid(-4000, 4000), colour(0, 255);
  std::vector<ColoredPoint> points(500);
  for (ColoredPoint& p : points) {
    // Multiples of 1/8: printed exactly by any sensible float formatting.
    p.x = grid(rng) / 8.0f;
    p.y = grid(rng) / 8.0f;
    p.z = grid(rng) / 8.0f;
    p.r = static_cast<uint8_t>(colour(rng));
    p.g = static_cast<uint8_t>(colour(rng));
    p.b = static_cast<uint8_t>(colour(rng));
  }
  const fs::path dir = fs::temp_directory_path() /
                       ("arscout_ply_pcl_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string ply = (dir / "cloud.ply").string();
  const std::string pcd = (dir / "cloud.pcd").string();
  write_ply(ply, points);
  const std::string command = std::string(tool) + " -format 0 " + ply + " " +
                              pcd + " > " + (dir / "log").string() + " 2>&1";
  ASSERT_EQ(std::system(command.c_str()), 0) << command;

  // ASCII PCD: a header ending in "DATA ascii", then "x y z rgb" with the
  // colour packed as 0xRRGGBB.
  std::ifstream in(pcd);
  std::string line;
  std::string fields;
  while (std::getline(in, line) && line != "DATA ascii")
    if (line.rfind("FIELDS", 0) == 0) fields = line;
  EXPECT_EQ(fields, "FIELDS x y z rgb");
  size_t read = 0;
  double x, y, z;
  uint32_t rgb;
  while (in >> x >> y >> z >> rgb) {
    ASSERT_LT(read, points.size());
    const ColoredPoint& p = points[read++];
    EXPECT_EQ(x, p.x);
    EXPECT_EQ(y, p.y);
    EXPECT_EQ(z, p.z);
    EXPECT_EQ(rgb, (uint32_t{p.r} << 16) | (uint32_t{p.g} << 8) | p.b);
  }
  EXPECT_EQ(read, points.size());
  fs::remove_all(dir);
}

}  // namespace
}  // namespace arscout::engine
