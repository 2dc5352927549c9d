#include "model_eval.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string_view>
#include <type_traits>
#include <utility>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <GeographicLib/LocalCartesian.hpp>

namespace arscout::eval {
namespace {

// Reads a text file line by line and knows where it is, so every parse
// error can name the file and line.
class LineReader {
 public:
  explicit LineReader(std::string path) : path_(std::move(path)), in_(path_) {
    if (!in_) throw std::runtime_error(path_ + ": cannot open");
  }

  // The next line, whatever it holds (a COLMAP POINTS2D line may be empty).
  bool next_raw(std::string& line) {
    if (!std::getline(in_, line)) return false;
    ++line_no_;
    // Tolerate files written on Windows.
    if (!line.empty() && line.back() == '\r') line.pop_back();
    return true;
  }

  // The next line that is neither blank nor a '#' comment.
  bool next_content(std::string& line) {
    while (next_raw(line)) {
      const auto first = line.find_first_not_of(" \t");
      if (first != std::string::npos && line[first] != '#') return true;
    }
    return false;
  }

  [[noreturn]] void fail(const std::string& what) const {
    throw std::runtime_error(path_ + ":" + std::to_string(line_no_) + ": " +
                             what);
  }

  int line_no() const { return line_no_; }

 private:
  std::string path_;
  std::ifstream in_;
  int line_no_ = 0;
};

// Whitespace-separated fields; views into `line`, which must outlive them.
std::vector<std::string_view> split_ws(std::string_view line) {
  std::vector<std::string_view> fields;
  std::size_t pos = 0;
  while (true) {
    pos = line.find_first_not_of(" \t", pos);
    if (pos == std::string_view::npos) break;
    auto end = line.find_first_of(" \t", pos);
    if (end == std::string_view::npos) end = line.size();
    fields.push_back(line.substr(pos, end - pos));
    pos = end;
  }
  return fields;
}

std::string_view trim(std::string_view s) {
  const auto first = s.find_first_not_of(" \t\r\n");
  if (first == std::string_view::npos) return {};
  const auto last = s.find_last_not_of(" \t\r\n");
  return s.substr(first, last - first + 1);
}

// from_chars rather than stod: no locale, no exceptions, and trailing
// garbage ("1.5x") is caught instead of silently ignored.
template <typename T>
T parse_number(std::string_view field, const LineReader& in, const char* what) {
  T value{};
  const char* begin = field.data();
  const char* end = begin + field.size();
  // from_chars rejects a leading '+', which some writers emit.
  if (begin != end && *begin == '+') ++begin;
  const auto [ptr, ec] = std::from_chars(begin, end, value);
  if (ec != std::errc() || ptr != end || begin == end) {
    in.fail(std::string("bad ") + what + " '" + std::string(field) + "'");
  }
  if constexpr (std::is_floating_point_v<T>) {
    if (!std::isfinite(value)) {
      in.fail(std::string("non-finite ") + what + " '" + std::string(field) +
              "'");
    }
  }
  return value;
}

double parse_double(std::string_view field, const LineReader& in,
                    const char* what) {
  return parse_number<double>(field, in, what);
}

// Ground-truth files store rotations to about six digits, so they are only
// orthonormal to ~1e-6; snapping to the nearest rotation keeps R and the
// derived t consistent. Returns false when `m` is not close to a rotation.
bool nearest_rotation(const Eigen::Matrix3d& m, Eigen::Matrix3d* out) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(
      m, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Matrix3d r = svd.matrixU() * svd.matrixV().transpose();
  if (r.determinant() < 0 || (r - m).norm() > 1e-3) return false;
  *out = r;
  return true;
}

Eigen::Matrix3d rotation_from(const std::vector<double>& v, std::size_t at,
                              const LineReader& in, const char* what) {
  Eigen::Matrix3d m;
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 3; ++col) m(row, col) = v[at + 3 * row + col];
  }
  Eigen::Matrix3d r;
  if (!nearest_rotation(m, &r)) in.fail(std::string(what) + " is no rotation");
  return r;
}

// ---- COLMAP images.txt ----

// IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME
Pose parse_image_header(const std::string& line, const LineReader& in) {
  const auto f = split_ws(line);
  if (f.size() < 10) {
    in.fail("expected IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME");
  }
  parse_number<long long>(f[0], in, "IMAGE_ID");
  double v[7];
  for (int i = 0; i < 7; ++i) v[i] = parse_double(f[1 + i], in, "number");
  Eigen::Quaterniond q(v[0], v[1], v[2], v[3]);
  if (std::abs(q.norm() - 1) > 1e-3) in.fail("quaternion is not unit length");
  Pose pose;
  pose.R = q.normalized().toRotationMatrix();
  pose.t = Eigen::Vector3d(v[4], v[5], v[6]);
  pose.camera_id = parse_number<int>(f[8], in, "CAMERA_ID");
  // The name is the rest of the line, so names with spaces survive.
  const auto name_at = static_cast<std::size_t>(f[9].data() - line.data());
  pose.name = std::string(trim(std::string_view(line).substr(name_at)));
  return pose;
}

struct Point2D {
  Eigen::Vector2d xy;
  long long point3d_id = -1;  // -1: not a point's observation
};

// X Y POINT3D_ID triples.
std::vector<Point2D> parse_points2d(const std::string& line,
                                    const LineReader& in) {
  const auto f = split_ws(line);
  if (f.size() % 3 != 0) in.fail("POINTS2D line is not (X Y POINT3D_ID)*");
  std::vector<Point2D> points;
  for (std::size_t i = 0; i < f.size(); i += 3) {
    Point2D p;
    p.xy.x() = parse_double(f[i], in, "X");
    p.xy.y() = parse_double(f[i + 1], in, "Y");
    p.point3d_id = parse_number<long long>(f[i + 2], in, "POINT3D_ID");
    points.push_back(p);
  }
  return points;
}

// ---- Geo CSV ----

std::vector<std::string_view> split_csv(std::string_view line) {
  std::vector<std::string_view> fields;
  std::size_t pos = 0;
  while (true) {
    const auto comma = line.find(',', pos);
    fields.push_back(trim(line.substr(pos, comma - pos)));
    if (comma == std::string_view::npos) break;
    pos = comma + 1;
  }
  return fields;
}

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(c));
  return out;
}

// Column index of each of image, latitude, longitude, altitude.
std::array<std::size_t, 4> geo_columns(const std::string& header,
                                       const LineReader& in) {
  static constexpr const char* kNames[4] = {"image", "latitude", "longitude",
                                            "altitude"};
  const auto fields = split_csv(header);
  std::array<std::size_t, 4> index;
  for (int k = 0; k < 4; ++k) {
    auto it = std::find_if(fields.begin(), fields.end(),
                           [&](auto f) { return lower(f) == kNames[k]; });
    if (it == fields.end()) {
      in.fail(std::string("header has no '") + kNames[k] + "' column");
    }
    index[k] = static_cast<std::size_t>(it - fields.begin());
  }
  return index;
}

GeoRow parse_geo_row(const std::vector<std::string_view>& f,
                     const std::array<std::size_t, 4>& col,
                     const LineReader& in) {
  GeoRow row;
  row.lat = parse_double(f[col[1]], in, "latitude");
  row.lon = parse_double(f[col[2]], in, "longitude");
  row.alt = parse_double(f[col[3]], in, "altitude");
  if (std::abs(row.lat) > 90 || std::abs(row.lon) > 180) {
    in.fail("latitude/longitude out of range");
  }
  return row;
}

// ---- Statistics ----

double max_of(const std::vector<double>& values) {
  return values.empty() ? std::numeric_limits<double>::quiet_NaN()
                        : *std::max_element(values.begin(), values.end());
}

double rms_spread(const std::vector<Eigen::Vector3d>& points) {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const auto& p : points) centroid += p;
  centroid /= static_cast<double>(points.size());
  double sum = 0;
  for (const auto& p : points) sum += (p - centroid).squaredNorm();
  return std::sqrt(sum / static_cast<double>(points.size()));
}

Eigen::Matrix3Xd to_matrix(const std::vector<Eigen::Vector3d>& points) {
  Eigen::Matrix3Xd m(3, points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    m.col(static_cast<Eigen::Index>(i)) = points[i];
  }
  return m;
}

// (estimated, true) for every name in both, in name order.
std::vector<std::pair<const Pose*, const Pose*>> common_poses(
    const std::map<std::string, Pose>& estimated,
    const std::map<std::string, Pose>& truth) {
  std::vector<std::pair<const Pose*, const Pose*>> pairs;
  for (const auto& [name, pose] : estimated) {
    if (auto it = truth.find(name); it != truth.end()) {
      pairs.emplace_back(&pose, &it->second);
    }
  }
  return pairs;
}

CameraError camera_error(const Similarity& alignment, const Pose& estimated,
                         const Pose& truth) {
  const Pose aligned = transform_pose(alignment, estimated);
  const Eigen::Vector3d offset = aligned.centre() - truth.centre();
  const Eigen::Vector3d in_camera = truth.R * offset;
  return {truth.name, offset.norm(), rotation_angle_deg(truth.R, aligned.R),
          std::abs(in_camera.z()), in_camera.head<2>().norm()};
}

void summarise_errors(PoseComparison& c) {
  std::vector<double> centre, rotation;
  for (const auto& e : c.cameras) {
    centre.push_back(e.centre_error);
    rotation.push_back(e.rotation_error_deg);
  }
  c.median_centre_error = median(centre);
  c.max_centre_error = max_of(centre);
  c.median_rotation_error_deg = median(rotation);
  c.max_rotation_error_deg = max_of(rotation);
}

// True when the points all (numerically) coincide, relative to how far they
// are from the origin, so georeferenced coordinates are judged fairly.
bool coincident(const std::vector<Eigen::Vector3d>& points) {
  double extent = 1;
  for (const auto& p : points)
    extent = std::max(extent, p.cwiseAbs().maxCoeff());
  return rms_spread(points) <= 1e-12 * extent;
}

}  // namespace

Pose Pose::from_centre(std::string name, const Eigen::Matrix3d& R,
                       const Eigen::Vector3d& C) {
  Pose pose;
  pose.name = std::move(name);
  pose.R = R;
  pose.t = -R * C;
  return pose;
}

std::map<std::string, Pose> read_colmap_images_txt(const std::string& path) {
  LineReader in(path);
  std::map<std::string, Pose> poses;
  std::string line;
  while (in.next_content(line)) {
    Pose pose = parse_image_header(line, in);
    const int header_line = in.line_no();
    // The POINTS2D line follows directly and may be empty; a writer that
    // drops the very last (empty) one still gives a usable file. The
    // keypoints are only checked here; read_colmap_tracks keeps them.
    if (in.next_raw(line)) parse_points2d(line, in);
    if (poses.count(pose.name)) {
      throw std::runtime_error(path + ":" + std::to_string(header_line) +
                               ": duplicate image name '" + pose.name + "'");
    }
    poses.emplace(pose.name, std::move(pose));
  }
  return poses;
}

Tracks read_colmap_tracks(const std::string& images_txt) {
  LineReader in(images_txt);
  Tracks tracks;
  std::string line;
  while (in.next_content(line)) {
    const Pose pose = parse_image_header(line, in);
    if (!in.next_raw(line)) break;
    for (const Point2D& p : parse_points2d(line, in)) {
      if (p.point3d_id < 0) continue;
      tracks[static_cast<std::uint64_t>(p.point3d_id)].push_back(
          {pose.name, p.xy});
    }
  }
  return tracks;
}

std::map<int, ColmapCamera> read_colmap_cameras_txt(const std::string& path) {
  LineReader in(path);
  std::map<int, ColmapCamera> cameras;
  std::string line;
  while (in.next_content(line)) {
    const auto f = split_ws(line);
    if (f.size() < 4) in.fail("expected CAMERA_ID MODEL WIDTH HEIGHT PARAMS[]");
    ColmapCamera cam;
    cam.id = parse_number<int>(f[0], in, "CAMERA_ID");
    cam.model = std::string(f[1]);
    cam.width = parse_number<int>(f[2], in, "WIDTH");
    cam.height = parse_number<int>(f[3], in, "HEIGHT");
    for (std::size_t i = 4; i < f.size(); ++i) {
      cam.params.push_back(parse_double(f[i], in, "parameter"));
    }
    if (!cameras.emplace(cam.id, cam).second) in.fail("duplicate CAMERA_ID");
  }
  return cameras;
}

std::vector<ColmapPoint3D> read_colmap_points3d_txt(const std::string& path) {
  LineReader in(path);
  std::vector<ColmapPoint3D> points;
  std::string line;
  while (in.next_content(line)) {
    const auto f = split_ws(line);
    if (f.size() < 8 || (f.size() - 8) % 2 != 0) {
      in.fail("expected POINT3D_ID X Y Z R G B ERROR (IMAGE_ID POINT2D_IDX)*");
    }
    ColmapPoint3D p;
    p.id = parse_number<std::uint64_t>(f[0], in, "POINT3D_ID");
    for (int i = 0; i < 3; ++i) p.xyz[i] = parse_double(f[1 + i], in, "X/Y/Z");
    for (int i = 0; i < 3; ++i) {
      p.rgb[i] = parse_number<int>(f[4 + i], in, "R/G/B");
      if (p.rgb[i] < 0 || p.rgb[i] > 255) in.fail("colour outside 0..255");
    }
    p.error = parse_double(f[7], in, "ERROR");
    for (std::size_t i = 8; i < f.size(); ++i) {
      parse_number<long long>(f[i], in, "track entry");
    }
    p.track_length = static_cast<int>((f.size() - 8) / 2);
    points.push_back(p);
  }
  return points;
}

namespace {

Pose read_strecha_camera(const std::filesystem::path& file) {
  LineReader in(file.string());
  std::vector<double> v;
  std::string line;
  while (in.next_content(line)) {
    for (auto field : split_ws(line))
      v.push_back(parse_double(field, in, "number"));
  }
  if (v.size() != 26) {
    in.fail("expected 26 numbers (K, distortion, R, C, size), found " +
            std::to_string(v.size()));
  }
  // Layout: K 0..8, distortion 9..11, R 12..20, C 21..23, width height.
  const Eigen::Matrix3d cam_to_world = rotation_from(v, 12, in, "R");
  const Eigen::Vector3d C(v[21], v[22], v[23]);
  return Pose::from_centre(file.stem().string(), cam_to_world.transpose(), C);
}

}  // namespace

std::map<std::string, Pose> read_strecha_ground_truth(
    const std::string& gt_dense_cameras_dir) {
  namespace fs = std::filesystem;
  if (!fs::is_directory(gt_dense_cameras_dir)) {
    throw std::runtime_error(gt_dense_cameras_dir + ": not a directory");
  }
  std::map<std::string, Pose> poses;
  for (const auto& entry : fs::directory_iterator(gt_dense_cameras_dir)) {
    if (!entry.is_regular_file() || entry.path().extension() != ".camera") {
      continue;
    }
    Pose pose = read_strecha_camera(entry.path());
    poses.emplace(pose.name, std::move(pose));
  }
  if (poses.empty()) {
    throw std::runtime_error(gt_dense_cameras_dir + ": no *.camera files");
  }
  return poses;
}

std::map<std::string, Pose> read_middlebury_par(const std::string& par_txt) {
  LineReader in(par_txt);
  std::string line;
  if (!in.next_content(line)) in.fail("empty file, expected the image count");
  const auto count_fields = split_ws(line);
  if (count_fields.size() != 1) in.fail("first line must be the image count");
  const int count = parse_number<int>(count_fields[0], in, "image count");

  std::map<std::string, Pose> poses;
  while (in.next_content(line)) {
    const auto f = split_ws(line);
    if (f.size() != 22) in.fail("expected name k11..k33 r11..r33 t1 t2 t3");
    std::vector<double> v;
    for (std::size_t i = 1; i < f.size(); ++i) {
      v.push_back(parse_double(f[i], in, "number"));
    }
    Pose pose;
    pose.name = std::string(f[0]);
    pose.R = rotation_from(v, 9, in, "R");
    pose.t = Eigen::Vector3d(v[18], v[19], v[20]);
    if (!poses.emplace(pose.name, pose).second) in.fail("duplicate name");
  }
  if (static_cast<int>(poses.size()) != count) {
    in.fail("header says " + std::to_string(count) + " images, found " +
            std::to_string(poses.size()));
  }
  return poses;
}

std::map<std::string, GeoRow> read_geo_csv(const std::string& path) {
  LineReader in(path);
  std::string line;
  if (!in.next_content(line)) in.fail("empty file, expected a header");
  const auto col = geo_columns(line, in);
  const std::size_t needed = *std::max_element(col.begin(), col.end()) + 1;

  std::map<std::string, GeoRow> rows;
  while (in.next_content(line)) {
    const auto f = split_csv(line);
    if (f.size() < needed) in.fail("too few columns");
    const std::string name(f[col[0]]);
    if (name.empty()) in.fail("empty image name");
    if (!rows.emplace(name, parse_geo_row(f, col, in)).second) {
      in.fail("duplicate image '" + name + "'");
    }
  }
  return rows;
}

Similarity fit_similarity(const std::vector<Eigen::Vector3d>& from,
                          const std::vector<Eigen::Vector3d>& to) {
  if (from.size() != to.size()) {
    throw std::invalid_argument("fit_similarity: point counts differ");
  }
  if (from.size() < 3) {
    throw std::invalid_argument("fit_similarity: needs at least 3 points");
  }
  // Umeyama divides by the source spread; all-equal points give no scale.
  if (coincident(from) || coincident(to)) {
    throw std::invalid_argument("fit_similarity: points coincide");
  }
  const Eigen::Matrix4d T =
      Eigen::umeyama(to_matrix(from), to_matrix(to), true);
  const Eigen::Matrix3d sR = T.topLeftCorner<3, 3>();
  Similarity sim;
  sim.scale = std::cbrt(sR.determinant());
  sim.R = sR / sim.scale;
  sim.t = T.topRightCorner<3, 1>();
  return sim;
}

Similarity fit_similarity_robust(const std::vector<Eigen::Vector3d>& from,
                                 const std::vector<Eigen::Vector3d>& to,
                                 int* used) {
  Similarity sim = fit_similarity(from, to);
  std::vector<bool> kept(from.size(), true);
  for (int round = 0; round < 10; ++round) {
    std::vector<double> residuals;
    for (size_t i = 0; i < from.size(); ++i)
      residuals.push_back((sim.apply(from[i]) - to[i]).norm());
    std::vector<double> sorted = residuals;
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2,
                     sorted.end());
    const double limit = 5 * sorted[sorted.size() / 2];
    std::vector<bool> within(from.size());
    std::vector<Eigen::Vector3d> a, b;
    for (size_t i = 0; i < from.size(); ++i) {
      within[i] = residuals[i] <= limit;
      if (!within[i]) continue;
      a.push_back(from[i]);
      b.push_back(to[i]);
    }
    if (within == kept || a.size() < 3) break;
    kept = within;
    sim = fit_similarity(a, b);
  }
  if (used)
    *used = static_cast<int>(std::count(kept.begin(), kept.end(), true));
  return sim;
}

Pose transform_pose(const Similarity& sim, const Pose& pose) {
  // Camera-to-world R^T becomes sim.R * R^T, so world-to-camera R sim.R^T.
  Pose out = Pose::from_centre(pose.name, pose.R * sim.R.transpose(),
                               sim.apply(pose.centre()));
  out.camera_id = pose.camera_id;
  return out;
}

double rotation_angle_deg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  Eigen::Quaterniond q(Eigen::Matrix3d(a * b.transpose()));
  q.normalize();
  // atan2 keeps full precision near 0, where acos((trace - 1) / 2) loses it.
  const double angle = 2 * std::atan2(q.vec().norm(), std::abs(q.w()));
  return angle * 180 / std::numbers::pi;
}

namespace {

// Median angle between the true orientations and the aligned estimated ones
// after the rotation Q that best maps all of the latter onto the former (in
// the chordal sense: Q maximises the sum of trace(G_i^T Q A_i) over
// camera-to-world rotations A_i estimated, G_i true) is applied to them.
double median_relative_rotation_error(
    const Similarity& alignment,
    const std::vector<std::pair<const Pose*, const Pose*>>& pairs) {
  Eigen::Matrix3d correlation = Eigen::Matrix3d::Zero();
  std::vector<Pose> aligned;
  for (const auto& [est, tru] : pairs) {
    aligned.push_back(transform_pose(alignment, *est));
    correlation += tru->R.transpose() * aligned.back().R;
  }
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(
      correlation, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d sign = Eigen::Matrix3d::Identity();
  sign(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant();
  const Eigen::Matrix3d common =
      svd.matrixU() * sign * svd.matrixV().transpose();
  std::vector<double> errors;
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    // World-to-camera: the camera-to-world common * A_i^T transposed.
    errors.push_back(rotation_angle_deg(pairs[i].second->R,
                                        aligned[i].R * common.transpose()));
  }
  return median(errors);
}

}  // namespace

PoseComparison compare_to_ground_truth(
    const std::map<std::string, Pose>& estimated,
    const std::map<std::string, Pose>& truth) {
  const auto pairs = common_poses(estimated, truth);
  if (pairs.size() < 3) {
    throw std::invalid_argument(
        "compare_to_ground_truth: " + std::to_string(pairs.size()) +
        " image names in common with the ground truth, need at least 3");
  }
  std::vector<Eigen::Vector3d> from, to;
  for (const auto& [est, tru] : pairs) {
    from.push_back(est->centre());
    to.push_back(tru->centre());
  }

  PoseComparison result;
  result.matched = static_cast<int>(pairs.size());
  result.truth_count = static_cast<int>(truth.size());
  result.alignment = fit_similarity(from, to);
  result.scene_scale = rms_spread(to);
  for (const auto& [est, tru] : pairs) {
    result.cameras.push_back(camera_error(result.alignment, *est, *tru));
  }
  summarise_errors(result);
  result.median_relative_rotation_error_deg =
      median_relative_rotation_error(result.alignment, pairs);
  return result;
}

double median_geo_distance(const std::map<std::string, GeoRow>& a,
                           const std::map<std::string, GeoRow>& b,
                           int* matched) {
  if (matched) *matched = 0;
  if (b.empty()) throw std::invalid_argument("median_geo_distance: b is empty");
  const GeoRow& origin = b.begin()->second;
  const GeographicLib::LocalCartesian enu(origin.lat, origin.lon, origin.alt);
  auto to_enu = [&](const GeoRow& g) {
    Eigen::Vector3d p;
    enu.Forward(g.lat, g.lon, g.alt, p.x(), p.y(), p.z());
    return p;
  };
  std::vector<double> distances;
  for (const auto& [name, row] : a) {
    if (auto it = b.find(name); it != b.end()) {
      distances.push_back((to_enu(row) - to_enu(it->second)).norm());
    }
  }
  if (distances.empty()) {
    throw std::invalid_argument(
        "median_geo_distance: no image names in common");
  }
  if (matched) *matched = static_cast<int>(distances.size());
  return median(std::move(distances));
}

namespace {

// ---- Observation fit ----

// A camera in OpenCV's terms; every supported COLMAP model is a special case.
struct Intrinsics {
  double fx = 1, fy = 1, cx = 0, cy = 0;
  double k1 = 0, k2 = 0, p1 = 0, p2 = 0, k3 = 0, k4 = 0, k5 = 0, k6 = 0;

  // Exactly zero is how a writer says "none"; then no undistortion is done
  // and the residuals are the photo's own pixels.
  bool distorted() const {
    return k1 != 0 || k2 != 0 || p1 != 0 || p2 != 0 || k3 != 0 || k4 != 0 ||
           k5 != 0 || k6 != 0;
  }
};

Intrinsics intrinsics_of(const ColmapCamera& cam) {
  static const std::map<std::string, std::size_t> kParamCount{
      {"SIMPLE_PINHOLE", 3}, {"PINHOLE", 4}, {"SIMPLE_RADIAL", 4},
      {"RADIAL", 5},         {"OPENCV", 8},  {"FULL_OPENCV", 12}};
  const std::string what = "fit_observations: camera " +
                           std::to_string(cam.id) + " (" + cam.model + ")";
  const auto count = kParamCount.find(cam.model);
  if (count == kParamCount.end()) {
    throw std::invalid_argument(what + ": unsupported model");
  }
  const auto& p = cam.params;
  if (p.size() != count->second) {
    throw std::invalid_argument(
        what + ": expected " + std::to_string(count->second) +
        " parameters, found " + std::to_string(p.size()));
  }
  Intrinsics k;
  if (cam.model.starts_with("SIMPLE_") || cam.model == "RADIAL") {
    // f cx cy [k1 [k2]]
    k.fx = k.fy = p[0];
    k.cx = p[1];
    k.cy = p[2];
    if (p.size() > 3) k.k1 = p[3];
    if (p.size() > 4) k.k2 = p[4];
    return k;
  }
  // fx fy cx cy [k1 k2 p1 p2 [k3 k4 k5 k6]]
  double* const fields[] = {&k.fx, &k.fy, &k.cx, &k.cy, &k.k1, &k.k2,
                            &k.p1, &k.p2, &k.k3, &k.k4, &k.k5, &k.k6};
  for (std::size_t i = 0; i < p.size(); ++i) *fields[i] = p[i];
  return k;
}

// Image name -> intrinsics, for the images that have a pose (others never
// take part, so their cameras need not be supported).
std::map<std::string, Intrinsics> intrinsics_by_image(
    const std::map<std::string, Pose>& poses,
    const std::map<int, ColmapCamera>& cameras,
    const std::map<std::string, int>& camera_ids) {
  std::map<std::string, Intrinsics> out;
  for (const auto& [name, id] : camera_ids) {
    if (!poses.count(name)) continue;
    const auto cam = cameras.find(id);
    if (cam == cameras.end()) {
      throw std::invalid_argument("fit_observations: image '" + name +
                                  "' has camera " + std::to_string(id) +
                                  ", which is not among the cameras");
    }
    out.emplace(name, intrinsics_of(cam->second));
  }
  return out;
}

// OpenCV's distortion of a normalised point x: x * radial + tangential.
struct DistortionTerms {
  double radial = 1;
  Eigen::Vector2d tangential = Eigen::Vector2d::Zero();
};

DistortionTerms distortion_at(const Intrinsics& k, const Eigen::Vector2d& x) {
  const double r2 = x.squaredNorm(), r4 = r2 * r2, r6 = r4 * r2;
  const double xy = x.x() * x.y();
  DistortionTerms d;
  d.radial = (1 + k.k1 * r2 + k.k2 * r4 + k.k3 * r6) /
             (1 + k.k4 * r2 + k.k5 * r4 + k.k6 * r6);
  d.tangential = {2 * k.p1 * xy + k.p2 * (r2 + 2 * x.x() * x.x()),
                  k.p1 * (r2 + 2 * x.y() * x.y()) + 2 * k.p2 * xy};
  return d;
}

// Inverts the distortion by fixed-point iteration, as cv::undistortPoints:
// x = (x_d - tangential(x)) / radial(x). It converges linearly at the rate
// of the distortion's slope, which is small for real lenses; 20 iterations
// leave far less than a millipixel.
Eigen::Vector2d undistort(const Intrinsics& k, const Eigen::Vector2d& xd) {
  Eigen::Vector2d x = xd;
  for (int i = 0; i < 20; ++i) {
    const DistortionTerms d = distortion_at(k, x);
    x = (xd - d.tangential) / d.radial;
  }
  return x;
}

// A keypoint in COLMAP pixels as an undistorted normalised point. COLMAP's
// principal point follows the keypoints' convention, so no half-pixel shift.
Eigen::Vector2d normalised(const Intrinsics& k, const Eigen::Vector2d& px) {
  const Eigen::Vector2d xd((px.x() - k.cx) / k.fx, (px.y() - k.cy) / k.fy);
  return k.distorted() ? undistort(k, xd) : xd;
}

// One observation ready to triangulate: the pose, the undistorted
// normalised keypoint, and the focal lengths that turn normalised residuals
// into pixels.
struct View {
  const std::string* image = nullptr;
  const Pose* pose = nullptr;
  Eigen::Vector2d x = Eigen::Vector2d::Zero();
  Eigen::Vector2d focal = Eigen::Vector2d::Ones();
};

// The track's observations in images that have a pose.
std::vector<View> views_of(const std::vector<TrackObservation>& track,
                           const std::map<std::string, Pose>& poses,
                           const std::map<std::string, Intrinsics>& by_image) {
  std::vector<View> views;
  for (const auto& obs : track) {
    const auto pose = poses.find(obs.image);
    if (pose == poses.end()) continue;
    const auto k = by_image.find(obs.image);
    if (k == by_image.end()) {
      throw std::invalid_argument("fit_observations: image '" + obs.image +
                                  "' has no camera id");
    }
    views.push_back({&obs.image, &pose->second, normalised(k->second, obs.xy),
                     Eigen::Vector2d(k->second.fx, k->second.fy)});
  }
  return views;
}

// Linear N-view triangulation: each view gives the rows x P3 - P1 and
// y P3 - P2 of A X = 0, with P = [R | t] (normalised coordinates keep A well
// conditioned); X is A's right singular vector of least singular value.
// False for a point at infinity.
bool triangulate_dlt(const std::vector<View>& views, Eigen::Vector3d* X) {
  Eigen::MatrixX4d A(2 * views.size(), 4);
  for (std::size_t i = 0; i < views.size(); ++i) {
    Eigen::Matrix<double, 3, 4> P;
    P << views[i].pose->R, views[i].pose->t;
    const auto row = static_cast<Eigen::Index>(2 * i);
    A.row(row) = views[i].x.x() * P.row(2) - P.row(0);
    A.row(row + 1) = views[i].x.y() * P.row(2) - P.row(1);
  }
  const Eigen::JacobiSVD<Eigen::MatrixX4d> svd(A, Eigen::ComputeThinV);
  const Eigen::Vector4d h = svd.matrixV().col(3);
  if (std::abs(h.w()) <= 1e-12 * h.head<3>().norm()) return false;
  *X = h.head<3>() / h.w();
  return X->allFinite();
}

// A view's reprojection residual in pixels and, if J is given, its
// derivative with respect to the point.
Eigen::Vector2d residual_px(const View& v, const Eigen::Vector3d& X,
                            Eigen::Matrix<double, 2, 3>* J) {
  const Eigen::Vector3d c = v.pose->R * X + v.pose->t;
  const Eigen::Vector2d r = v.focal.cwiseProduct(c.head<2>() / c.z() - v.x);
  if (J) {
    Eigen::Matrix<double, 2, 3> d_projection;
    d_projection << 1 / c.z(), 0, -c.x() / (c.z() * c.z()),  //
        0, 1 / c.z(), -c.y() / (c.z() * c.z());
    *J = v.focal.asDiagonal() * d_projection * v.pose->R;
  }
  return r;
}

// Gauss-Newton on the pixel residuals: the DLT minimises an algebraic error,
// not the reprojection error the bundle adjustment minimised, and comparing
// poses fairly needs each one's best point. From the DLT start it converges
// in a few steps; 10 leave a margin.
void refine_point(const std::vector<View>& views, Eigen::Vector3d* X) {
  for (int iteration = 0; iteration < 10; ++iteration) {
    Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
    Eigen::Vector3d g = Eigen::Vector3d::Zero();
    for (const View& v : views) {
      Eigen::Matrix<double, 2, 3> J;
      const Eigen::Vector2d r = residual_px(v, *X, &J);
      H += J.transpose() * J;
      g += J.transpose() * r;
    }
    const Eigen::Vector3d step = H.ldlt().solve(-g);
    if (!step.allFinite()) return;
    *X += step;
    if (step.norm() <= 1e-12 * X->norm()) return;
  }
}

bool in_front_of_all(const std::vector<View>& views, const Eigen::Vector3d& X) {
  return std::all_of(views.begin(), views.end(), [&](const View& v) {
    return (v.pose->R * X + v.pose->t).z() > 0;
  });
}

// The point that best explains the views; false when it ends at infinity or
// behind one of the cameras, where a residual would mean nothing.
bool triangulate(const std::vector<View>& views, Eigen::Vector3d* X) {
  if (!triangulate_dlt(views, X)) return false;
  refine_point(views, X);
  return X->allFinite() && in_front_of_all(views, *X);
}

// The q-quantile, interpolating linearly between order statistics.
double quantile(std::vector<double> values, double q) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(values.begin(), values.end());
  const double at = q * static_cast<double>(values.size() - 1);
  const auto lower = static_cast<std::size_t>(at);
  if (lower + 1 >= values.size()) return values.back();
  const double frac = at - static_cast<double>(lower);
  return values[lower] * (1 - frac) + values[lower + 1] * frac;
}

// The mean of min(residual, 4 px): 4 px is the reconstruction's outlier
// threshold, so a few gross mismatches cannot dominate the mean.
double mean_clipped(const std::vector<double>& values) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  double sum = 0;
  for (double v : values) sum += std::min(v, 4.0);
  return sum / static_cast<double>(values.size());
}

}  // namespace

ObservationFit fit_observations(const std::map<std::string, Pose>& poses,
                                const std::map<int, ColmapCamera>& cameras,
                                const std::map<std::string, int>& camera_ids,
                                const Tracks& tracks) {
  const auto by_image = intrinsics_by_image(poses, cameras, camera_ids);
  ObservationFit fit;
  std::vector<double> all;
  std::map<std::string, std::vector<double>> per_image;
  for (const auto& entry : tracks) {
    const auto views = views_of(entry.second, poses, by_image);
    if (views.size() < 2) continue;
    Eigen::Vector3d X;
    if (!triangulate(views, &X)) {
      ++fit.skipped_points;
      continue;
    }
    ++fit.points;
    for (const View& v : views) {
      all.push_back(residual_px(v, X, nullptr).norm());
      per_image[*v.image].push_back(all.back());
    }
  }
  fit.observations = static_cast<int>(all.size());
  fit.median_px = median(all);
  fit.mean_clipped_px = mean_clipped(all);
  fit.p90_px = quantile(all, 0.9);
  for (auto& [name, residuals] : per_image) {
    fit.image_median_px[name] = median(std::move(residuals));
  }
  return fit;
}

double median(std::vector<double> values) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  const auto mid =
      values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  if (values.size() % 2 == 1) return *mid;
  // Even count: the lower middle is the largest of the lower half.
  const double lower_mid = *std::max_element(values.begin(), mid);
  return (lower_mid + *mid) / 2;
}

}  // namespace arscout::eval
