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

// X Y POINT3D_ID triples; only checked, the evaluation does not use them.
void check_points2d(const std::string& line, const LineReader& in) {
  const auto f = split_ws(line);
  if (f.size() % 3 != 0) in.fail("POINTS2D line is not (X Y POINT3D_ID)*");
  for (std::size_t i = 0; i < f.size(); i += 3) {
    parse_double(f[i], in, "X");
    parse_double(f[i + 1], in, "Y");
    parse_number<long long>(f[i + 2], in, "POINT3D_ID");
  }
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
    // drops the very last (empty) one still gives a usable file.
    if (in.next_raw(line)) check_points2d(line, in);
    if (poses.count(pose.name)) {
      throw std::runtime_error(path + ":" + std::to_string(header_line) +
                               ": duplicate image name '" + pose.name + "'");
    }
    poses.emplace(pose.name, std::move(pose));
  }
  return poses;
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
