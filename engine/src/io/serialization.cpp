#include "io/serialization.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string_view>
#include <type_traits>

#include "arscout/util/bytes.h"
#include "arscout/util/compress.h"
#include "features/feature_extractor.h"
#include "features/keypoint_refinement.h"

namespace arscout::engine {
namespace {

constexpr char kMagic[8] = {'A', 'R', 'S', 'C', 'E', 'N', 'E', '1'};
// Version 2 added the per-image flag for features kept apart.
// Version 3 adds the keypoint patches and the refined keypoints.
// Version 4 adds each image's component and scout, and the next component
// id.
// Version 5 leaves out each image's point per keypoint (8 bytes for each of
// up to 3000 keypoints, most of them -1: about 40 % of a walk's state, which
// the service writes every 30 s): the tracks name the same links, and
// reading rebuilds them.
constexpr uint32_t kVersion = 5;
constexpr char kFeaturesMagic[8] = {'A', 'R', 'S', 'F', 'E', 'A', 'T', '1'};
// Features with patches.
constexpr char kFeaturesMagic2[8] = {'A', 'R', 'S', 'F', 'E', 'A', 'T', '2'};
// The form written now: after the id, the size of the features' bytes and
// those bytes deflated; in them the descriptors as two bytes per component
// where they are whole steps (feature_extractor.h), half the size.
constexpr char kFeaturesMagic3[8] = {'A', 'R', 'S', 'F', 'E', 'A', 'T', '3'};
// How the descriptors of ARSFEAT3 are written.
enum class DescriptorForm : uint8_t { kFloats = 0, kSteps = 1 };
// Deflate expands no stream by more than this: a larger stated size is
// damage, refused before anything is allocated for it.
constexpr uint64_t kMaxDeflateRatio = 1032;
constexpr int kPatchBytes = kPatchSide * kPatchSide;

// The state's raw pieces (vectors of pods, structs, std::arrays) are their
// in-memory bytes, as the first version wrote them; numbers alone would be
// little-endian on any host, the raw pieces only on a little-endian one.
static_assert(std::endian::native == std::endian::little,
              "the state format is little-endian; add byte swapping here");

// The state's pieces over util::ByteWriter: lengths as uint64, strings and
// vectors as a length then their bytes, fixed-size Eigen matrices as their
// doubles in storage (column-major) order.
class Writer {
 public:
  // Numbers little-endian; any other trivially copyable value (a struct, a
  // std::array, a C array) as its bytes in memory.
  template <typename T>
  void pod(const T& value) {
    static_assert(std::is_trivially_copyable_v<T>);
    if constexpr (util::ByteNumber<T>) {
      out_.put(value);
    } else {
      out_.append(&value, sizeof(T));
    }
  }
  void size(size_t n) { out_.put<uint64_t>(n); }
  void str(const std::string& s) {
    size(s.size());
    out_.append(s);
  }
  template <typename T>
  void vec(const std::vector<T>& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    size(v.size());
    if (!v.empty()) out_.append(v.data(), v.size() * sizeof(T));
  }
  // Fixed-size Eigen matrices: their coefficients, column-major.
  template <typename Derived>
  void matrix(const Eigen::MatrixBase<Derived>& m) {
    for (Eigen::Index i = 0; i < m.size(); ++i)
      out_.put<double>(m.derived().data()[i]);
  }
  void points2(const std::vector<Eigen::Vector2d>& points) {
    size(points.size());
    for (const auto& p : points) matrix(p);
  }
  void index_pairs(const std::vector<std::pair<int, int>>& pairs) {
    size(pairs.size());
    for (const auto& [a, b] : pairs) {
      pod(a);
      pod(b);
    }
  }
  std::string take() { return out_.take(); }

 private:
  util::ByteWriter out_;
};

// The inverse of Writer over util::ByteReader. Every failure throws
// std::runtime_error "engine state is damaged or from another version: ..."
// (callers and tests match on it).
class Reader {
 public:
  explicit Reader(std::string_view in)
      : in_(in, "engine state is damaged or from another version: ") {}
  template <typename T>
  T pod() {
    static_assert(std::is_trivially_copyable_v<T>);
    if constexpr (util::ByteNumber<T>) {
      return in_.get<T>();
    } else {
      T value;
      std::memcpy(&value, in_.take(sizeof(T)).data(), sizeof(T));
      return value;
    }
  }
  // A length can be no longer than the whole input: bounds every
  // allocation by the bytes given, before anything is allocated.
  size_t size() {
    const uint64_t n = in_.get<uint64_t>();
    if (n > in_.size()) fail("a length beyond the end");
    return static_cast<size_t>(n);
  }
  std::string str() {
    const size_t n = size();
    return std::string(in_.take(n));
  }
  template <typename T>
  std::vector<T> vec() {
    static_assert(std::is_trivially_copyable_v<T>);
    const size_t n = size();
    const std::string_view raw = in_.take(n * sizeof(T));
    std::vector<T> v(n);
    if (n) std::memcpy(v.data(), raw.data(), raw.size());
    return v;
  }
  template <typename Matrix>
  Matrix matrix() {
    Matrix m;
    for (Eigen::Index i = 0; i < m.size(); ++i) m.data()[i] = in_.get<double>();
    return m;
  }
  std::vector<Eigen::Vector2d> points2() {
    const size_t n = size();
    need(n * 2 * sizeof(double));
    std::vector<Eigen::Vector2d> points(n);
    for (auto& p : points) p = matrix<Eigen::Vector2d>();
    return points;
  }
  std::vector<std::pair<int, int>> index_pairs() {
    const size_t n = size();
    need(n * 2 * sizeof(int));
    std::vector<std::pair<int, int>> pairs(n);
    for (auto& [a, b] : pairs) {
      a = pod<int>();
      b = pod<int>();
    }
    return pairs;
  }
  bool done() const { return in_.done(); }
  [[noreturn]] void fail(const std::string& what) const { in_.fail(what); }

 private:
  // Before allocating for n bytes' worth: fails as reading them would.
  void need(size_t n) const {
    if (in_.left() < n) fail("truncated");
  }

  util::ByteReader in_;
};

void write_intrinsics(Writer& w, const CameraIntrinsics& c) {
  w.pod(c.width);
  w.pod(c.height);
  for (double v : {c.fx, c.fy, c.cx, c.cy, c.k1, c.k2, c.p1, c.p2, c.k3})
    w.pod(v);
  w.str(c.source);
}

CameraIntrinsics read_intrinsics(Reader& r) {
  CameraIntrinsics c;
  c.width = r.pod<int>();
  c.height = r.pod<int>();
  for (double* v :
       {&c.fx, &c.fy, &c.cx, &c.cy, &c.k1, &c.k2, &c.p1, &c.p2, &c.k3}) {
    *v = r.pod<double>();
  }
  c.source = r.str();
  return c;
}

void write_fix(Writer& w, const std::optional<GeoFix>& fix) {
  w.pod<uint8_t>(fix ? 1 : 0);
  if (!fix) return;
  w.pod(fix->lat);
  w.pod(fix->lon);
  w.pod<uint8_t>(fix->alt ? 1 : 0);
  w.pod(fix->alt.value_or(0));
  w.pod(fix->h_acc);
  w.pod(fix->v_acc);
}

std::optional<GeoFix> read_fix(Reader& r) {
  if (!r.pod<uint8_t>()) return std::nullopt;
  GeoFix fix;
  fix.lat = r.pod<double>();
  fix.lon = r.pod<double>();
  const bool has_alt = r.pod<uint8_t>();
  const double alt = r.pod<double>();
  if (has_alt) fix.alt = alt;
  fix.h_acc = r.pod<double>();
  fix.v_acc = r.pod<double>();
  return fix;
}

// A matrix as its row count, then (when it has rows) all its values.
template <typename T>
void write_rows(Writer& w, const cv::Mat& m) {
  w.pod(m.rows);
  if (m.rows > 0) w.vec(std::vector<T>(m.ptr<T>(0), m.ptr<T>(0) + m.total()));
}

// The inverse of write_rows for a matrix of `cols` columns of `type`;
// `what` names it in errors.
template <typename T>
cv::Mat read_rows(Reader& r, int cols, int type, const std::string& what) {
  const int rows = r.pod<int>();
  if (rows < 0) r.fail(what + " count");
  if (rows == 0) return cv::Mat(0, cols, type);
  // Read (and so bound by the input's length) before allocating.
  const std::vector<T> values = r.vec<T>();
  if (values.size() != static_cast<size_t>(rows) * cols) r.fail(what + " size");
  cv::Mat m(rows, cols, type);
  std::memcpy(m.ptr<T>(0), values.data(), values.size() * sizeof(T));
  return m;
}

// True when every component is a whole number of steps from 0 to
// kMaxDescriptorSteps, so that two bytes hold it exactly.
bool in_whole_steps(const cv::Mat& descriptors) {
  for (int r = 0; r < descriptors.rows; ++r) {
    const float* row = descriptors.ptr<float>(r);
    for (int c = 0; c < descriptors.cols; ++c) {
      const float steps = row[c] * kDescriptorSteps;
      if (!(steps >= 0 && steps <= kMaxDescriptorSteps &&
            steps == std::round(steps)))
        return false;
    }
  }
  return true;
}

// Extracted descriptors as 16-bit steps; any others (made by hand, or extracted
// before they were quantized) as their floats, so that every one reads
// back to the same bits.
void write_descriptors(Writer& w, const cv::Mat& descriptors) {
  if (descriptors.rows == 0 || !in_whole_steps(descriptors)) {
    w.pod(DescriptorForm::kFloats);
    write_rows<float>(w, descriptors);
    return;
  }
  w.pod(DescriptorForm::kSteps);
  cv::Mat steps;
  descriptors.convertTo(steps, CV_16U, kDescriptorSteps);
  write_rows<uint16_t>(w, steps);
}

cv::Mat read_descriptors(Reader& r) {
  const auto form = r.pod<DescriptorForm>();
  if (form == DescriptorForm::kFloats)
    return read_rows<float>(r, 128, CV_32F, "descriptor");
  if (form != DescriptorForm::kSteps) r.fail("descriptor form");
  const cv::Mat steps = read_rows<uint16_t>(r, 128, CV_16U, "descriptor");
  cv::Mat descriptors;
  steps.convertTo(descriptors, CV_32F, 1.0 / kDescriptorSteps);
  return descriptors;
}

// `compact`: the descriptors as write_descriptors writes them (ARSFEAT3);
// else as floats (the scene's inline features).
void write_features(Writer& w, const SceneImage& image, bool compact) {
  w.points2(image.keypoints);
  if (compact)
    write_descriptors(w, image.descriptors);
  else
    write_rows<float>(w, image.descriptors);
  w.vec(image.colors);
  write_rows<uint8_t>(w, image.patches);
}

void read_features(Reader& r, SceneImage& image, bool with_patches,
                   bool compact = false) {
  image.keypoints = r.points2();
  image.descriptors = compact ? read_descriptors(r)
                              : read_rows<float>(r, 128, CV_32F, "descriptor");
  image.colors = r.vec<std::array<uint8_t, 3>>();
  image.patches = with_patches
                      ? read_rows<uint8_t>(r, kPatchBytes, CV_8U, "patch")
                      : cv::Mat();
}

// ARSFEAT3's deflated part, after the id.
void read_deflated_features(Reader& r, SceneImage& image) {
  const auto size = r.pod<uint64_t>();
  const std::string deflated = r.str();
  if (size > kMaxDeflateRatio * (deflated.size() + 1))
    r.fail("the features of " + image.id + " state an impossible size");
  std::string raw;
  try {
    raw = util::inflate_bytes(deflated, static_cast<size_t>(size));
  } catch (const std::runtime_error& e) {
    r.fail("the features of " + image.id + ": " + e.what());
  }
  Reader inner(raw);
  read_features(inner, image, /*with_patches=*/true, /*compact=*/true);
  if (!inner.done()) r.fail("trailing bytes in the features of " + image.id);
}

// An image's features from their own bytes (serialize_features).
void attach_features(const std::string& bytes, SceneImage& image) {
  Reader r(bytes);
  const auto magic = r.pod<std::array<char, 8>>();
  const auto is = [&](const char* m) {
    return std::memcmp(magic.data(), m, 8) == 0;
  };
  if (!is(kFeaturesMagic) && !is(kFeaturesMagic2) && !is(kFeaturesMagic3))
    r.fail("the features of " + image.id + " are not features");
  if (r.str() != image.id)
    r.fail("the features of " + image.id + " are another's");
  if (is(kFeaturesMagic3))
    read_deflated_features(r, image);
  else
    read_features(r, image, is(kFeaturesMagic2));
  if (!r.done()) r.fail("trailing bytes after the features of " + image.id);
}

void write_image(Writer& w, const SceneImage& image, bool features_apart) {
  w.str(image.id);
  w.pod(image.camera);
  w.pod<uint8_t>(image.removed);
  w.pod(image.width);
  w.pod(image.height);
  write_fix(w, image.gps);
  w.matrix(image.gps_enu);
  const bool apart = features_apart && !image.keypoints.empty();
  w.pod<uint8_t>(apart ? 0 : 1);
  if (!apart) write_features(w, image, /*compact=*/false);
  w.size(image.refined_keypoints.size());
  for (const auto& [keypoint, position] : image.refined_keypoints) {
    w.pod(keypoint);
    w.matrix(position);
  }
  w.pod<uint8_t>(image.registered);
  w.pod(static_cast<int>(image.status));
  w.str(image.reason);
  w.pod(image.pose_inliers);
  w.matrix(image.q.coeffs());
  w.matrix(image.t);
  w.pod(image.component);
  w.str(image.scout);
}

// The refined positions overwrite the detected ones the features hold (and
// rewrite the same bits where the features were written refined).
void read_refined_keypoints(Reader& r, SceneImage& image) {
  const size_t n = r.size();
  image.refined_keypoints.reserve(n);
  for (size_t i = 0; i < n; ++i) {
    const int keypoint = r.pod<int>();
    const Eigen::Vector2d position = r.matrix<Eigen::Vector2d>();
    if (keypoint < 0 || keypoint >= static_cast<int>(image.keypoints.size()))
      r.fail("refined keypoint of image " + image.id + " out of range");
    image.keypoints[keypoint] = position;
    image.refined_keypoints.emplace_back(keypoint, position);
  }
}

SceneImage read_image(Reader& r, uint32_t version,
                      const FeatureSource& features) {
  SceneImage image;
  image.id = r.str();
  image.camera = r.pod<int>();
  image.removed = r.pod<uint8_t>();
  image.width = r.pod<int>();
  image.height = r.pod<int>();
  image.gps = read_fix(r);
  image.gps_enu = r.matrix<Eigen::Vector3d>();
  const bool inline_features = version < 2 || r.pod<uint8_t>() != 0;
  if (inline_features) {
    read_features(r, image, version >= 3);
  } else {
    if (!features) r.fail("the features of " + image.id + " are kept apart");
    attach_features(features(image.id), image);
  }
  if (version >= 5)
    image.point_of.assign(image.keypoints.size(), -1);
  else
    image.point_of = r.vec<int64_t>();
  if (version >= 3) read_refined_keypoints(r, image);
  image.registered = r.pod<uint8_t>();
  const int status = r.pod<int>();
  if (status < static_cast<int>(CaptureStatus::kRegistered) ||
      status > static_cast<int>(CaptureStatus::kRejected)) {
    r.fail("capture status");
  }
  image.status = static_cast<CaptureStatus>(status);
  image.reason = r.str();
  image.pose_inliers = r.pod<int>();
  image.q.coeffs() = r.matrix<Eigen::Vector4d>();
  image.t = r.matrix<Eigen::Vector3d>();
  // States before components held one model: component 0.
  image.component = version >= 4 ? r.pod<int>() : 0;
  if (image.component < 0) r.fail("component of image " + image.id);
  if (version >= 4) image.scout = r.str();
  if (image.point_of.size() != image.keypoints.size() ||
      image.colors.size() != image.keypoints.size() ||
      image.descriptors.rows != static_cast<int>(image.keypoints.size()) ||
      (!image.patches.empty() &&
       image.patches.rows != static_cast<int>(image.keypoints.size()))) {
    r.fail("per-keypoint arrays of image " + image.id + " differ in length");
  }
  return image;
}

void write_pair(Writer& w, const std::pair<int, int>& key,
                const ImagePair& pair) {
  w.pod(key.first);
  w.pod(key.second);
  w.index_pairs(pair.matches);
  w.matrix(pair.R);
  w.matrix(pair.t);
  w.pod(pair.median_angle_deg);
  w.pod(pair.homography_ratio);
}

void read_pair(Reader& r, Scene& scene) {
  const int first = r.pod<int>();
  const int second = r.pod<int>();
  ImagePair& pair = scene.pairs[{first, second}];
  pair.matches = r.index_pairs();
  pair.R = r.matrix<Eigen::Matrix3d>();
  pair.t = r.matrix<Eigen::Vector3d>();
  pair.median_angle_deg = r.pod<double>();
  pair.homography_ratio = r.pod<double>();
}

// Indices must stay in range, or a damaged state would crash later. With
// `link_tracks` (version 5 on) each observation also sets its keypoint's
// point, and two points may not claim one keypoint; before, the stored
// links had to agree with the tracks.
void check_indices(const Reader& r, Scene& scene, bool link_tracks) {
  for (const SceneImage& image : scene.images) {
    if (image.camera < 0 ||
        image.camera >= static_cast<int>(scene.cameras.size())) {
      r.fail("camera index");
    }
  }
  for (const auto& [key, pair] : scene.pairs) {
    if (key.first < 0 || key.second >= static_cast<int>(scene.images.size()) ||
        key.first >= key.second) {
      r.fail("pair index");
    }
    const size_t n1 = scene.images[key.first].keypoints.size();
    const size_t n2 = scene.images[key.second].keypoints.size();
    for (const auto& [k1, k2] : pair.matches) {
      if (k1 < 0 || k2 < 0 || static_cast<size_t>(k1) >= n1 ||
          static_cast<size_t>(k2) >= n2) {
        r.fail("match keypoint index");
      }
    }
  }
  // Links read from the state (before version 5) must name points; linked
  // from the tracks they are all -1 yet.
  for (size_t i = 0; !link_tracks && i < scene.images.size(); ++i) {
    for (int64_t point : scene.images[i].point_of) {
      if (point >= 0 && !scene.points.count(point))
        r.fail("keypoint names a missing point");
    }
  }
  for (const auto& [id, point] : scene.points) {
    for (const Observation& obs : point.track) {
      if (obs.image < 0 || obs.image >= static_cast<int>(scene.images.size()) ||
          obs.keypoint < 0 ||
          obs.keypoint >=
              static_cast<int>(scene.images[obs.image].keypoints.size())) {
        r.fail("observation index");
      }
      int64_t& linked = scene.images[obs.image].point_of[obs.keypoint];
      if (link_tracks) {
        if (linked >= 0) r.fail("two tracks claim one keypoint");
        linked = id;
      } else if (linked != id) {
        r.fail("a track and its keypoint disagree");
      }
    }
  }
}

}  // namespace

std::string serialize_features(const SceneImage& image) {
  Writer features;
  write_features(features, image, /*compact=*/true);
  const std::string raw = features.take();
  Writer w;
  w.pod(kFeaturesMagic3);
  w.str(image.id);
  w.pod<uint64_t>(raw.size());
  w.str(util::deflate_bytes(raw));
  return w.take();
}

std::string serialize_scene(const Scene& scene, bool features_apart) {
  Writer w;
  w.pod(kMagic);
  w.pod(kVersion);
  w.size(scene.cameras.size());
  for (const SceneCamera& camera : scene.cameras) {
    w.str(camera.id);
    write_intrinsics(w, camera.original);
    w.pod(camera.scale);
    w.pod(camera.params);
    w.pod<uint8_t>(camera.refine);
  }
  w.size(scene.images.size());
  for (const SceneImage& image : scene.images)
    write_image(w, image, features_apart);
  // By the later image of each pair: a new image's pairs come last, so
  // that the bytes of the older ones stay as they were (the service stores
  // the state in parts, and writes only the changed ones).
  std::vector<const std::pair<const std::pair<int, int>, ImagePair>*> pairs;
  for (const auto& entry : scene.pairs) pairs.push_back(&entry);
  std::stable_sort(pairs.begin(), pairs.end(), [](auto* a, auto* b) {
    return std::max(a->first.first, a->first.second) <
           std::max(b->first.first, b->first.second);
  });
  w.size(pairs.size());
  for (const auto* entry : pairs) write_pair(w, entry->first, entry->second);
  w.size(scene.points.size());
  for (const auto& [id, point] : scene.points) {
    w.pod(id);
    w.matrix(point.xyz);
    w.pod(point.rgb);
    w.vec(point.track);
  }
  w.pod(scene.next_point_id);
  w.pod<uint8_t>(scene.enu_origin ? 1 : 0);
  w.pod(scene.enu_origin.value_or(Geodetic{}));
  w.pod<uint8_t>(scene.geo_registered);
  w.pod<uint8_t>(scene.initialized);
  w.pod(scene.registered_at_last_global_ba);
  w.pod(scene.reference_image);
  w.pod(scene.scale_image);
  w.pod(scene.next_component);
  return w.take();
}

Scene deserialize_scene(const std::string& bytes,
                        const FeatureSource& features) {
  Reader r(bytes);
  const auto magic = r.pod<std::array<char, 8>>();
  if (std::memcmp(magic.data(), kMagic, 8) != 0)
    r.fail("not an arscout engine state");
  const uint32_t version = r.pod<uint32_t>();
  if (version < 1 || version > kVersion) r.fail("unsupported version");
  Scene scene;
  scene.cameras.resize(r.size());
  for (SceneCamera& camera : scene.cameras) {
    camera.id = r.str();
    camera.original = read_intrinsics(r);
    camera.scale = r.pod<double>();
    camera.params = r.pod<std::array<double, 6>>();
    camera.refine = r.pod<uint8_t>();
  }
  const size_t images = r.size();
  for (size_t i = 0; i < images; ++i)
    scene.images.push_back(read_image(r, version, features));
  const size_t pairs = r.size();
  for (size_t i = 0; i < pairs; ++i) read_pair(r, scene);
  const size_t points = r.size();
  for (size_t i = 0; i < points; ++i) {
    const auto id = r.pod<int64_t>();
    ScenePoint& point = scene.points[id];
    point.xyz = r.matrix<Eigen::Vector3d>();
    point.rgb = r.pod<std::array<uint8_t, 3>>();
    point.track = r.vec<Observation>();
  }
  scene.next_point_id = r.pod<int64_t>();
  const bool has_origin = r.pod<uint8_t>();
  const auto origin = r.pod<Geodetic>();
  if (has_origin) scene.enu_origin = origin;
  scene.geo_registered = r.pod<uint8_t>();
  scene.initialized = r.pod<uint8_t>();
  scene.registered_at_last_global_ba = r.pod<int>();
  scene.reference_image = r.pod<int>();
  scene.scale_image = r.pod<int>();
  if (version >= 4) scene.next_component = r.pod<int>();
  if (!r.done()) r.fail("trailing bytes");
  check_indices(r, scene, /*link_tracks=*/version >= 5);
  return scene;
}

}  // namespace arscout::engine
