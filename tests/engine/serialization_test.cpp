// The Scene's byte layout: a round trip restores every field to the bit,
// and bytes that are not a whole, consistent scene are refused with
// std::runtime_error, never a crash or a scene that would crash later.
#include "io/serialization.h"

#include "arscout/util/bytes.h"
#include "features/feature_extractor.h"
#include "features/keypoint_refinement.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "synthetic_scene.h"

namespace arscout::engine {
namespace {

// Bit patterns, so that -0.0 differs from 0.0 and NaN payloads count.
uint64_t bits(double value) { return std::bit_cast<uint64_t>(value); }

template <typename Derived>
std::vector<uint64_t> bits(const Eigen::MatrixBase<Derived>& m) {
  std::vector<uint64_t> out;
  for (Eigen::Index i = 0; i < m.size(); ++i)
    out.push_back(bits(m.derived().data()[i]));
  return out;
}

void expect_identical(const CameraIntrinsics& a, const CameraIntrinsics& b) {
  EXPECT_EQ(a.width, b.width);
  EXPECT_EQ(a.height, b.height);
  const double CameraIntrinsics::*fields[] = {
      &CameraIntrinsics::fx, &CameraIntrinsics::fy, &CameraIntrinsics::cx,
      &CameraIntrinsics::cy, &CameraIntrinsics::k1, &CameraIntrinsics::k2,
      &CameraIntrinsics::p1, &CameraIntrinsics::p2, &CameraIntrinsics::k3};
  for (auto field : fields) EXPECT_EQ(bits(a.*field), bits(b.*field));
  EXPECT_EQ(a.source, b.source);
}

void expect_identical(const std::optional<GeoFix>& a,
                      const std::optional<GeoFix>& b) {
  ASSERT_EQ(a.has_value(), b.has_value());
  if (!a) return;
  EXPECT_EQ(bits(a->lat), bits(b->lat));
  EXPECT_EQ(bits(a->lon), bits(b->lon));
  ASSERT_EQ(a->alt.has_value(), b->alt.has_value());
  if (a->alt) {
    EXPECT_EQ(bits(*a->alt), bits(*b->alt));
  }
  EXPECT_EQ(bits(a->h_acc), bits(b->h_acc));
  EXPECT_EQ(bits(a->v_acc), bits(b->v_acc));
}

void expect_identical(const cv::Mat& a, const cv::Mat& b) {
  ASSERT_EQ(a.rows, b.rows);
  if (a.rows == 0) return;
  ASSERT_EQ(a.cols, b.cols);
  ASSERT_EQ(a.type(), b.type());
  for (int r = 0; r < a.rows; ++r) {
    ASSERT_EQ(std::memcmp(a.ptr(r), b.ptr(r), a.cols * a.elemSize()), 0)
        << "row " << r;
  }
}

void expect_identical(const SceneImage& a, const SceneImage& b) {
  SCOPED_TRACE("image " + a.id);
  EXPECT_EQ(a.id, b.id);
  EXPECT_EQ(a.camera, b.camera);
  EXPECT_EQ(a.removed, b.removed);
  EXPECT_EQ(a.width, b.width);
  EXPECT_EQ(a.height, b.height);
  expect_identical(a.gps, b.gps);
  EXPECT_EQ(bits(a.gps_enu), bits(b.gps_enu));
  ASSERT_EQ(a.keypoints.size(), b.keypoints.size());
  for (size_t k = 0; k < a.keypoints.size(); ++k) {
    EXPECT_EQ(bits(a.keypoints[k]), bits(b.keypoints[k]));
  }
  expect_identical(a.descriptors, b.descriptors);
  EXPECT_EQ(a.colors, b.colors);
  expect_identical(a.patches, b.patches);
  ASSERT_EQ(a.refined_keypoints.size(), b.refined_keypoints.size());
  for (size_t k = 0; k < a.refined_keypoints.size(); ++k) {
    EXPECT_EQ(a.refined_keypoints[k].first, b.refined_keypoints[k].first);
    EXPECT_EQ(bits(a.refined_keypoints[k].second),
              bits(b.refined_keypoints[k].second));
  }
  EXPECT_EQ(a.point_of, b.point_of);
  EXPECT_EQ(a.registered, b.registered);
  EXPECT_EQ(a.component, b.component);
  EXPECT_EQ(a.scout, b.scout);
  EXPECT_EQ(a.status, b.status);
  EXPECT_EQ(a.reason, b.reason);
  EXPECT_EQ(a.pose_inliers, b.pose_inliers);
  EXPECT_EQ(bits(a.q.coeffs()), bits(b.q.coeffs()));
  EXPECT_EQ(bits(a.t), bits(b.t));
}

void expect_identical(const Scene& a, const Scene& b) {
  ASSERT_EQ(a.cameras.size(), b.cameras.size());
  for (size_t c = 0; c < a.cameras.size(); ++c) {
    SCOPED_TRACE("camera " + a.cameras[c].id);
    EXPECT_EQ(a.cameras[c].id, b.cameras[c].id);
    expect_identical(a.cameras[c].original, b.cameras[c].original);
    EXPECT_EQ(bits(a.cameras[c].scale), bits(b.cameras[c].scale));
    for (int k = 0; k < 6; ++k) {
      EXPECT_EQ(bits(a.cameras[c].params[k]), bits(b.cameras[c].params[k]));
    }
    EXPECT_EQ(a.cameras[c].refine, b.cameras[c].refine);
  }
  ASSERT_EQ(a.images.size(), b.images.size());
  for (size_t i = 0; i < a.images.size(); ++i)
    expect_identical(a.images[i], b.images[i]);
  ASSERT_EQ(a.pairs.size(), b.pairs.size());
  for (auto ia = a.pairs.begin(), ib = b.pairs.begin(); ia != a.pairs.end();
       ++ia, ++ib) {
    EXPECT_EQ(ia->first, ib->first);
    EXPECT_EQ(ia->second.matches, ib->second.matches);
    EXPECT_EQ(bits(ia->second.R), bits(ib->second.R));
    EXPECT_EQ(bits(ia->second.t), bits(ib->second.t));
    EXPECT_EQ(bits(ia->second.median_angle_deg),
              bits(ib->second.median_angle_deg));
    EXPECT_EQ(bits(ia->second.homography_ratio),
              bits(ib->second.homography_ratio));
  }
  ASSERT_EQ(a.points.size(), b.points.size());
  for (auto ia = a.points.begin(), ib = b.points.begin(); ia != a.points.end();
       ++ia, ++ib) {
    EXPECT_EQ(ia->first, ib->first);
    EXPECT_EQ(bits(ia->second.xyz), bits(ib->second.xyz));
    EXPECT_EQ(ia->second.rgb, ib->second.rgb);
    EXPECT_EQ(ia->second.track, ib->second.track);
  }
  EXPECT_EQ(a.next_point_id, b.next_point_id);
  ASSERT_EQ(a.enu_origin.has_value(), b.enu_origin.has_value());
  if (a.enu_origin) {
    EXPECT_EQ(bits(a.enu_origin->lat), bits(b.enu_origin->lat));
    EXPECT_EQ(bits(a.enu_origin->lon), bits(b.enu_origin->lon));
    EXPECT_EQ(bits(a.enu_origin->alt), bits(b.enu_origin->alt));
  }
  EXPECT_EQ(a.geo_registered, b.geo_registered);
  EXPECT_EQ(a.initialized, b.initialized);
  EXPECT_EQ(a.registered_at_last_global_ba, b.registered_at_last_global_ba);
  EXPECT_EQ(a.reference_image, b.reference_image);
  EXPECT_EQ(a.next_component, b.next_component);
  EXPECT_EQ(a.scale_image, b.scale_image);
}

// A scene that uses every field, with awkward values: a withdrawn image, a
// fix without altitude, a second camera with distortion, negative zero, a
// subnormal, the largest double, and matches between pairs of images.
Scene make_rich_scene(int images, int points, int clutter) {
  std::mt19937 rng(99);
  const synthetic::Truth truth = synthetic::make_truth(
      {.images = images, .arc_deg = 40, .radius_m = 15, .points = points}, rng);
  Scene scene = synthetic::make_scene(truth, 0.3, clutter, rng);

  SceneCamera second;
  second.id = "phone-b";
  second.original = guessed_camera(4032, 3024);
  second.original.k1 = -0.05;
  second.original.p2 = -0.0;
  second.original.k3 = std::numeric_limits<double>::denorm_min();
  second.original.source = "estimated";
  second.scale = 0.396825396825;
  second.params = {1234.5, 1234.5 * (1 + 1e-15),
                   799.5,  599.5,
                   -0.0,   std::numeric_limits<double>::max()};
  second.refine = true;
  scene.cameras.push_back(second);
  scene.images.back().camera = 1;

  scene.images[0].gps = GeoFix{47.3769, 8.5417, 408.25, 3.5, 6.0};
  scene.images[0].gps_enu = {0.1 + 0.2, -1e-300, 2.0 / 3.0};
  scene.images[1].gps = GeoFix{47.37691, 8.54171, std::nullopt, 12.0, 30.0};
  scene.images[1].gps_enu = {1.0 / 7.0, 5.5, -0.0};
  scene.images[1].pose_inliers = 123;
  scene.images[1].component = 7;  // a second component
  scene.images[1].scout = "bob";
  scene.next_component = 8;
  SceneImage& withdrawn = scene.images[images - 2];
  withdrawn.removed = true;
  withdrawn.registered = false;
  withdrawn.status = CaptureStatus::kRejected;
  withdrawn.reason = "too few matches (12 < 30) \xE2\x80\x94 retry";
  withdrawn.q = Eigen::Quaterniond::Identity();
  withdrawn.t.setZero();

  for (int i = 0; i + 1 < images; ++i) {
    ImagePair pair;
    // Keypoints of the same point in the two images.
    for (const auto& [id, point] : scene.points) {
      int mine = -1, theirs = -1;
      for (const Observation& obs : point.track) {
        if (obs.image == i) mine = obs.keypoint;
        if (obs.image == i + 1) theirs = obs.keypoint;
      }
      if (mine >= 0 && theirs >= 0) pair.matches.emplace_back(mine, theirs);
    }
    pair.R = (truth.poses[i + 1].q * truth.poses[i].q.conjugate())
                 .toRotationMatrix();
    pair.t = (truth.poses[i + 1].t - pair.R * truth.poses[i].t).normalized();
    pair.median_angle_deg = 9.87654321;
    pair.homography_ratio = 0.25 + i;
    scene.pairs[{i, i + 1}] = pair;
  }
  // Patches for every image with keypoints, and two keypoints of the first
  // image moved by refinement (the features kept apart hold them moved).
  for (SceneImage& image : scene.images) {
    image.patches = cv::Mat(static_cast<int>(image.keypoints.size()),
                            kPatchSide * kPatchSide, CV_8U);
    cv::randu(image.patches, 0, 256);
  }
  for (int k : {0, 2}) {
    SceneImage& image = scene.images[0];
    image.keypoints[k] += Eigen::Vector2d(0.125, -1.0 / 3.0);
    image.refined_keypoints.emplace_back(k, image.keypoints[k]);
  }
  scene.points.begin()->second.rgb = {255, 0, 128};
  scene.next_point_id += 17;  // ids of deleted points are never reused
  scene.enu_origin = Geodetic{47.3769, 8.5417, 408.25};
  scene.geo_registered = true;
  scene.registered_at_last_global_ba = 3;
  scene.reference_image = 0;
  scene.scale_image = images - 1;
  return scene;
}

TEST(SerializationTest, RoundTripRestoresEveryFieldBitExactly) {
  const Scene scene = make_rich_scene(5, 80, 7);
  ASSERT_GT(scene.points.size(), 50u);
  const std::string bytes = serialize_scene(scene);
  const Scene restored = deserialize_scene(bytes);
  expect_identical(scene, restored);
  // And the restored scene writes the same bytes: nothing is lost or
  // normalised on the way (a restored model continues exactly).
  EXPECT_EQ(serialize_scene(restored), bytes);
}

TEST(SerializationTest, RoundTripOfEmptyScene) {
  const Scene empty;
  const Scene restored = deserialize_scene(serialize_scene(empty));
  expect_identical(empty, restored);
  EXPECT_FALSE(restored.enu_origin.has_value());
  EXPECT_EQ(restored.reference_image, -1);
}

TEST(SerializationTest, RoundTripOfImageWithoutKeypoints) {
  Scene scene = make_rich_scene(3, 20, 0);
  SceneImage bare;
  bare.id = "no-features";
  bare.descriptors = cv::Mat(0, 128, CV_32F);
  scene.images.push_back(bare);
  const Scene restored = deserialize_scene(serialize_scene(scene));
  expect_identical(scene, restored);
  EXPECT_TRUE(restored.images.back().keypoints.empty());
}

// The features of every image by id, as a store keeping them apart would.
std::map<std::string, std::string> features_by_id(const Scene& scene) {
  std::map<std::string, std::string> features;
  for (const SceneImage& image : scene.images)
    if (!image.keypoints.empty())
      features[image.id] = serialize_features(image);
  return features;
}

TEST(SerializationTest, FeaturesKeptApartRestoreBitExactly) {
  const Scene scene = make_rich_scene(5, 80, 7);
  const std::string whole = serialize_scene(scene);
  const std::string bytes = serialize_scene(scene, /*features_apart=*/true);
  const auto features = features_by_id(scene);
  ASSERT_FALSE(features.empty());
  size_t feature_bytes = 0;
  for (const auto& [id, b] : features) feature_bytes += b.size();
  // The features are most of the state.
  EXPECT_LT(bytes.size(), whole.size() - feature_bytes / 2);
  std::vector<std::string> asked;
  const Scene restored = deserialize_scene(bytes, [&](const std::string& id) {
    asked.push_back(id);
    return features.at(id);
  });
  expect_identical(scene, restored);
  EXPECT_EQ(asked.size(), features.size());  // each once, none other
  EXPECT_EQ(serialize_scene(restored, true), bytes);
  EXPECT_EQ(serialize_scene(restored), whole);
}

// An image's features as ARSFEAT2 wrote them (ARSFEAT1: without the
// patches' count): the id, the keypoints, the descriptors as floats and
// the colours, each a little-endian count and then the values.
std::string features_as_written_before(const SceneImage& image, int magic) {
  util::ByteWriter w;
  w.append(std::string("ARSFEAT") + std::to_string(magic));
  w.put<uint64_t>(image.id.size());
  w.append(image.id);
  w.put<uint64_t>(image.keypoints.size());
  for (const Eigen::Vector2d& p : image.keypoints) {
    w.put(p.x());
    w.put(p.y());
  }
  w.put<int32_t>(image.descriptors.rows);
  if (image.descriptors.rows > 0) {
    w.put<uint64_t>(image.descriptors.total());
    w.append(image.descriptors.ptr<float>(0),
             image.descriptors.total() * sizeof(float));
  }
  w.put<uint64_t>(image.colors.size());
  w.append(image.colors.data(), image.colors.size() * 3);
  if (magic >= 2) {
    w.put<int32_t>(image.patches.rows);
    if (image.patches.rows > 0) {
      w.put<uint64_t>(image.patches.total());
      w.append(image.patches.ptr<uint8_t>(0), image.patches.total());
    }
  }
  return w.take();
}

// Features stored before the compact form (ARSFEAT2) and before patches
// were kept (ARSFEAT1) still attach, the latter without patches.
TEST(SerializationTest, FeaturesWrittenBeforeStillAttach) {
  for (const int magic : {1, 2}) {
    SCOPED_TRACE("ARSFEAT" + std::to_string(magic));
    Scene scene = make_rich_scene(3, 20, 0);
    if (magic == 1)
      for (SceneImage& image : scene.images) image.patches = cv::Mat();
    const std::string bytes = serialize_scene(scene, true);
    std::map<std::string, std::string> old;
    for (const SceneImage& image : scene.images)
      old[image.id] = features_as_written_before(image, magic);
    const Scene restored = deserialize_scene(
        bytes, [&](const std::string& id) { return old.at(id); });
    expect_identical(scene, restored);
  }
}

// Extracted descriptors (whole steps) are stored two bytes per component
// and read back to the same bits: without patches (the synthetic ones are
// noise, which nothing compresses), well under 0.6 of what floats took.
TEST(SerializationTest, QuantizedDescriptorsAreStoredCompactlyAndExactly) {
  for (const bool patches : {true, false}) {
    SCOPED_TRACE(patches ? "with patches" : "without patches");
    Scene scene = make_rich_scene(3, 200, 100);
    for (SceneImage& image : scene.images) {
      quantize_descriptors(image.descriptors);
      if (!patches) image.patches = cv::Mat();
    }
    const std::string bytes = serialize_scene(scene, true);
    const auto features = features_by_id(scene);
    for (const SceneImage& image : scene.images) {
      const std::string& compact = features.at(image.id);
      EXPECT_EQ(compact.substr(0, 8), "ARSFEAT3");
      if (!patches) {
        EXPECT_LT(compact.size() * 10,
                  features_as_written_before(image, 2).size() * 6)
            << image.id;
      }
    }
    const Scene restored = deserialize_scene(
        bytes, [&](const std::string& id) { return features.at(id); });
    expect_identical(scene, restored);
    EXPECT_EQ(features_by_id(restored), features);
  }
}

// A compact blob whose stated size or deflated bytes are wrong is refused.
TEST(SerializationTest, DamagedCompactFeaturesAreRefused) {
  Scene scene = make_rich_scene(3, 20, 0);
  for (SceneImage& image : scene.images)
    quantize_descriptors(image.descriptors);
  const std::string bytes = serialize_scene(scene, true);
  const auto features = features_by_id(scene);
  const std::string& id0 = scene.images[0].id;
  const size_t size_at = 8 + 8 + id0.size();
  for (const int change : {-1, +1, 1 << 30}) {
    std::string damaged = features.at(id0);
    uint64_t size = 0;
    std::memcpy(&size, damaged.data() + size_at, 8);
    size += change;
    std::memcpy(damaged.data() + size_at, &size, 8);
    EXPECT_THROW(deserialize_scene(bytes,
                                   [&](const std::string& id) {
                                     return id == id0 ? damaged
                                                      : features.at(id);
                                   }),
                 std::runtime_error)
        << change;
  }
  std::string flipped = features.at(id0);
  flipped[flipped.size() / 2] ^= 0x5a;
  EXPECT_THROW(deserialize_scene(bytes,
                                 [&](const std::string& id) {
                                   return id == id0 ? flipped : features.at(id);
                                 }),
               std::runtime_error);
}

TEST(SerializationTest, FeaturesKeptApartMustBeGivenAndBeTheirs) {
  const Scene scene = make_rich_scene(3, 20, 0);
  const std::string bytes = serialize_scene(scene, true);
  const auto features = features_by_id(scene);
  EXPECT_THROW(deserialize_scene(bytes), std::runtime_error);
  const std::string first = features.begin()->second;
  // Another image's features, damaged or truncated ones: refused.
  EXPECT_THROW(
      deserialize_scene(bytes, [&](const std::string&) { return first; }),
      std::runtime_error);
  for (size_t cut :
       {size_t{0}, size_t{5}, first.size() / 2, first.size() - 1}) {
    EXPECT_THROW(deserialize_scene(bytes,
                                   [&](const std::string& id) {
                                     return features.at(id).substr(0, cut);
                                   }),
                 std::runtime_error)
        << cut;
  }
  EXPECT_THROW(
      deserialize_scene(
          bytes, [&](const std::string& id) { return features.at(id) + '\0'; }),
      std::runtime_error);
}

// A scene without patches or refined keypoints as an older version wrote
// it: version 4 wrote each image's point per keypoint after its features
// (the tracks name them since version 5); version 3 had, besides, no
// component at the end of each image's record and no next component id at
// the end; version 2 had, besides, neither the patch count in an image's
// features nor the refined keypoints after its point ids; version 1 had,
// besides, no flag byte before the features (they were always inline).
std::string as_older_version(const Scene& scene, int version) {
  // Where each image's record starts: the first at its id (a length, then
  // the bytes), the others as far on as the records before them take.
  auto first_images = [&](size_t k) {
    Scene part = scene;
    part.images.resize(k);
    return serialize_scene(part).size();
  };
  std::string bytes = serialize_scene(scene);
  const std::string& id0 = scene.images[0].id;
  std::string id0_record(8, '\0');
  id0_record[0] = static_cast<char>(id0.size());
  const size_t first_record = bytes.find(id0_record + id0);
  EXPECT_NE(first_record, std::string::npos);
  struct Edit {
    size_t offset, erased;
    std::string inserted;
    bool operator<(const Edit& o) const { return offset < o.offset; }
  };
  std::vector<Edit> edits;
  for (size_t k = 0; k < scene.images.size(); ++k) {
    const SceneImage& image = scene.images[k];
    const size_t record = first_record + first_images(k) - first_images(0);
    const size_t fix = image.gps ? 1 + 8 + 8 + 1 + 8 + 8 + 8 : 1;
    const size_t flag = record + 8 + image.id.size() + 4 + 1 + 4 + 4 + fix + 24;
    const size_t n = image.keypoints.size();
    const size_t rows = static_cast<size_t>(image.descriptors.rows);
    const size_t patch_count = flag + 1 + (8 + 16 * n) + 4 +
                               (rows > 0 ? 8 + 512 * rows : 0) + (8 + 3 * n);
    // The point ids (a count, then one int64 each), where the refined
    // keypoints' count now starts; version 2 had no such count.
    std::string point_ids(8 + 8 * n, '\0');
    const uint64_t count = n;
    std::memcpy(point_ids.data(), &count, 8);
    for (size_t i = 0; i < n; ++i)
      std::memcpy(point_ids.data() + 8 + 8 * i, &image.point_of[i], 8);
    edits.push_back({patch_count + 4, version <= 2 ? 8u : 0u, point_ids});
    const size_t end = first_record + first_images(k + 1) - first_images(0);
    // The component and the scout (a length, then its bytes).
    if (version <= 3)
      edits.push_back(
          {end - 4 - 8 - image.scout.size(), 4 + 8 + image.scout.size(), ""});
    if (version <= 2) edits.push_back({patch_count, 4, ""});
    if (version == 1) edits.push_back({flag, 1, ""});
  }
  if (version <= 3)
    edits.push_back({bytes.size() - 4, 4, ""});  // the next component id
  std::sort(edits.rbegin(), edits.rend());
  for (const Edit& e : edits) bytes.replace(e.offset, e.erased, e.inserted);
  bytes[8] = static_cast<char>(version);  // the version after the magic
  return bytes;
}

TEST(SerializationTest, VersionsOneToFourStillRestore) {
  Scene scene = make_rich_scene(3, 20, 0);
  scene.pairs.clear();
  scene.points.clear();
  for (SceneImage& image : scene.images) {
    std::fill(image.point_of.begin(), image.point_of.end(), -1);
    image.patches = cv::Mat();
    image.refined_keypoints.clear();
    image.component = 0;  // older states held one model
    image.scout.clear();
  }
  scene.next_component = 1;
  for (int version : {1, 2, 3, 4}) {
    SCOPED_TRACE("version " + std::to_string(version));
    const Scene restored = deserialize_scene(as_older_version(scene, version));
    expect_identical(scene, restored);
  }
}

TEST(SerializationTest, TruncatedBytesThrow) {
  const std::string bytes = serialize_scene(make_rich_scene(3, 6, 1));
  ASSERT_LT(bytes.size(), 20000u);  // small enough to try every length
  for (size_t length = 0; length < bytes.size(); ++length) {
    EXPECT_THROW(deserialize_scene(bytes.substr(0, length)), std::runtime_error)
        << "prefix of " << length << " of " << bytes.size() << " bytes";
  }
  EXPECT_THROW(deserialize_scene(bytes + '\0'),
               std::runtime_error);  // trailing bytes
}

TEST(SerializationTest, WrongMagicOrVersionThrows) {
  const std::string bytes = serialize_scene(make_rich_scene(3, 6, 1));
  std::string damaged = bytes;
  damaged[0] = 'X';
  EXPECT_THROW(deserialize_scene(damaged), std::runtime_error);
  damaged = bytes;
  damaged[7] = '2';  // "ARSCENE2"
  EXPECT_THROW(deserialize_scene(damaged), std::runtime_error);
  damaged = bytes;
  damaged[8] =
      static_cast<char>(damaged[8] + 1);  // the version after the magic
  EXPECT_THROW(deserialize_scene(damaged), std::runtime_error);
  EXPECT_THROW(deserialize_scene("not a scene at all"), std::runtime_error);
  EXPECT_THROW(deserialize_scene(""), std::runtime_error);
}

// Scenes whose numbers are well-formed but whose indices point nowhere:
// written as they are (serialize does not check), refused on reading,
// because the mapper indexes with them unchecked.
class DamagedIndexTest : public ::testing::Test {
 protected:
  void expect_refused(const Scene& damaged) {
    const std::string bytes = serialize_scene(damaged);
    EXPECT_THROW(deserialize_scene(bytes), std::runtime_error);
  }
  Scene scene_ = make_rich_scene(4, 30, 2);
};

TEST_F(DamagedIndexTest, ValidSceneIsAccepted) {
  EXPECT_NO_THROW(deserialize_scene(serialize_scene(scene_)));
}

TEST_F(DamagedIndexTest, ImageCameraOutOfRange) {
  scene_.images[1].camera = 2;
  expect_refused(scene_);
  scene_.images[1].camera = -1;
  expect_refused(scene_);
}

TEST_F(DamagedIndexTest, TrackImageOutOfRange) {
  scene_.points.begin()->second.track.push_back({4, 0});
  expect_refused(scene_);
  scene_.points.begin()->second.track.back() = {-1, 0};
  expect_refused(scene_);
}

TEST_F(DamagedIndexTest, TrackKeypointOutOfRange) {
  const int keypoints = static_cast<int>(scene_.images[0].keypoints.size());
  scene_.points.begin()->second.track.push_back({0, keypoints});
  expect_refused(scene_);
  scene_.points.begin()->second.track.back() = {0, -1};
  expect_refused(scene_);
}

TEST_F(DamagedIndexTest, PairImagesOutOfRangeOrUnordered) {
  Scene damaged = scene_;
  damaged.pairs[{2, 4}] = ImagePair{};
  expect_refused(damaged);
  damaged = scene_;
  damaged.pairs[{2, 1}] = ImagePair{};  // pairs are keyed (first < second)
  expect_refused(damaged);
  damaged = scene_;
  damaged.pairs[{-1, 2}] = ImagePair{};
  expect_refused(damaged);
}

TEST_F(DamagedIndexTest, PerKeypointArraysDisagree) {
  Scene damaged = scene_;
  damaged.images[2].colors.push_back({1, 2, 3});
  expect_refused(damaged);
  damaged = scene_;
  damaged.images[2].descriptors =
      damaged.images[2].descriptors.rowRange(1, 3).clone();
  expect_refused(damaged);
}

// The mapper reads o.point_of[match.second] for every match of a pair, so a
// match naming a keypoint the image does not have would read out of bounds.
TEST_F(DamagedIndexTest, PairMatchKeypointOutOfRange) {
  ASSERT_TRUE(scene_.pairs.count({0, 1}));
  const int keypoints = static_cast<int>(scene_.images[1].keypoints.size());
  scene_.pairs[{0, 1}].matches.emplace_back(0, keypoints + 1000);
  expect_refused(scene_);
}

// Keypoints' points are rebuilt from the tracks: a keypoint two tracks
// claim has no single point, and the mapper assumes one.
TEST_F(DamagedIndexTest, TwoTracksClaimingOneKeypoint) {
  ASSERT_GE(scene_.points.size(), 2u);
  auto first = scene_.points.begin();
  const Observation claimed = first->second.track.front();
  std::next(first)->second.track.push_back(claimed);
  expect_refused(scene_);
}

// Flipping bits anywhere in a small valid state: the reader either refuses
// it with std::runtime_error or returns a scene, never crashes, never runs
// out of memory and never throws anything else.
TEST(SerializationTest, BitFlipsNeverCrash) {
  const std::string bytes = serialize_scene(make_rich_scene(3, 6, 1));
  int refused = 0;
  for (size_t at = 0; at < bytes.size(); ++at) {
    for (const unsigned char mask : {0x01, 0x10, 0x80, 0xFF}) {
      std::string damaged = bytes;
      damaged[at] = static_cast<char>(damaged[at] ^ mask);
      try {
        deserialize_scene(damaged);
      } catch (const std::runtime_error&) {
        ++refused;
      } catch (const std::exception& e) {
        ADD_FAILURE() << "byte " << at << " ^ " << int{mask} << ": "
                      << e.what();
      }
    }
  }
  EXPECT_GT(refused, 0);
}

}  // namespace
}  // namespace arscout::engine
