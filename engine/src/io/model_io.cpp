#include "arscout/engine/model_io.h"

#include <Eigen/Geometry>

#include <charconv>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <limits>
#include <map>
#include <set>
#include <stdexcept>
#include <string_view>

#include "arscout/engine/ply.h"

namespace arscout::engine {
namespace {

// COLMAP's pixel convention puts the centre of the top-left pixel at
// (0.5, 0.5), ours (OpenCV's) at (0, 0).
constexpr double kColmapPixelShift = 0.5;

// Enough digits that every double reads back bit for bit.
void full_precision(std::ostream& out) {
  out << std::setprecision(std::numeric_limits<double>::max_digits10);
}

// Writes `path` with `write`, throwing "PATH: cannot write" or "PATH: write
// failed".
template <typename Write>
void write_text_file(const std::string& path, Write write) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error(path + ": cannot write");
  write(out);
  out.close();
  if (!out) throw std::runtime_error(path + ": write failed");
}

void write_cameras(const Model& model, std::ostream& out) {
  full_precision(out);
  out << "# Camera list with one line of data per camera:\n"
      << "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
      << "# Number of cameras: " << model.cameras.size() << "\n";
  for (size_t i = 0; i < model.cameras.size(); ++i) {
    const CameraIntrinsics& c = model.cameras[i].intrinsics;
    out << i + 1 << (c.k3 != 0 ? " FULL_OPENCV " : " OPENCV ") << c.width << ' '
        << c.height << ' ' << c.fx << ' ' << c.fy << ' '
        << c.cx + kColmapPixelShift << ' ' << c.cy + kColmapPixelShift << ' '
        << c.k1 << ' ' << c.k2 << ' ' << c.p1 << ' ' << c.p2;
    if (c.k3 != 0) out << ' ' << c.k3 << " 0 0 0";
    out << '\n';
  }
}

void write_images(const Model& model, std::ostream& out) {
  full_precision(out);
  out << "# Image list with two lines of data per image:\n"
      << "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n"
      << "#   POINTS2D[] as (X, Y, POINT3D_ID)\n"
      << "# Number of images: " << model.images.size() << "\n";
  for (size_t i = 0; i < model.images.size(); ++i) {
    const ModelImage& image = model.images[i];
    out << i + 1;
    for (double v : image.qvec) out << ' ' << v;
    for (double v : image.tvec) out << ' ' << v;
    out << ' ' << image.camera + 1 << ' ' << image.id << '\n';
    for (size_t k = 0; k < image.keypoints.size(); ++k) {
      if (k) out << ' ';
      out << image.keypoints[k][0] + kColmapPixelShift << ' '
          << image.keypoints[k][1] + kColmapPixelShift << ' '
          << (image.point_ids[k] >= 0 ? image.point_ids[k] + 1 : -1);
    }
    out << '\n';
  }
}

void write_points(const Model& model, std::ostream& out) {
  full_precision(out);
  out << "# 3D point list with one line of data per point:\n"
      << "#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, "
         "POINT2D_IDX)\n"
      << "# Number of points: " << model.points.size() << "\n";
  for (const ModelPoint& point : model.points) {
    out << point.id + 1;
    for (double v : point.xyz) out << ' ' << v;
    for (uint8_t v : point.rgb) out << ' ' << static_cast<int>(v);
    out << ' ' << point.error_px;
    for (const auto& [image, keypoint] : point.track)
      out << ' ' << image + 1 << ' ' << keypoint;
    out << '\n';
  }
}

// Nearest float, an infinity beyond float's range (a plain cast would be
// undefined there).
float to_float(double value) {
  constexpr double kMax = std::numeric_limits<float>::max();
  constexpr double kRoundsToInfinity = kMax + 0x1p103;  // FLT_MAX + ulp/2
  if (value >= kRoundsToInfinity) return std::numeric_limits<float>::infinity();
  if (value <= -kRoundsToInfinity) {
    return -std::numeric_limits<float>::infinity();
  }
  return static_cast<float>(value);
}

// ---------------------------------------------------------------- reading

// A COLMAP text file, line by line, counting lines for messages.
class TextFile {
 public:
  explicit TextFile(std::string path) : path_(std::move(path)), in_(path_) {
    if (!in_) throw std::runtime_error(path_ + ": cannot read");
  }

  // The very next line, whatever it holds; false at the end.
  bool next_line(std::string& line) {
    if (!std::getline(in_, line)) return false;
    ++line_number_;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    return true;
  }
  // The next line that is neither blank nor a comment; false at the end.
  bool next_data_line(std::string& line) {
    while (next_line(line)) {
      const size_t first = line.find_first_not_of(" \t");
      if (first != std::string::npos && line[first] != '#') return true;
    }
    return false;
  }
  int line_number() const { return line_number_; }
  [[noreturn]] void fail(const std::string& what) const {
    throw std::runtime_error(path_ + ":" + std::to_string(line_number_) + ": " +
                             what);
  }

 private:
  std::string path_;
  std::ifstream in_;
  int line_number_ = 0;
};

// The whitespace-separated fields of one line; a missing or malformed
// field fails with the file's name and line.
class Fields {
 public:
  Fields(const TextFile& file, std::string_view line)
      : file_(file), line_(line) {}

  std::string_view word(const char* what) {
    skip_space();
    const size_t start = pos_;
    while (pos_ < line_.size() && !is_space(line_[pos_])) ++pos_;
    if (pos_ == start) file_.fail(std::string("missing ") + what);
    return line_.substr(start, pos_ - start);
  }
  double real(const char* what) { return number<double>(what); }
  int64_t integer(const char* what) { return number<int64_t>(what); }
  // An integer in [low, high].
  int64_t integer(const char* what, int64_t low, int64_t high) {
    const int64_t value = integer(what);
    if (value < low || value > high) {
      file_.fail(std::string(what) + " out of range: " + std::to_string(value));
    }
    return value;
  }
  bool at_end() {
    skip_space();
    return pos_ == line_.size();
  }
  // The rest of the line without surrounding white space.
  std::string_view rest() {
    skip_space();
    std::string_view rest = line_.substr(pos_);
    while (!rest.empty() && is_space(rest.back())) rest.remove_suffix(1);
    pos_ = line_.size();
    return rest;
  }
  void expect_end() {
    if (!at_end()) file_.fail("unexpected text after the last field");
  }

 private:
  static bool is_space(char c) { return c == ' ' || c == '\t'; }
  void skip_space() {
    while (pos_ < line_.size() && is_space(line_[pos_])) ++pos_;
  }
  template <class T>
  T number(const char* what) {
    const std::string_view text = word(what);
    T value{};
    const auto [end, ec] =
        std::from_chars(text.data(), text.data() + text.size(), value);
    if (ec != std::errc() || end != text.data() + text.size()) {
      file_.fail(std::string("bad ") + what + " '" + std::string(text) + "'");
    }
    return value;
  }

  const TextFile& file_;
  std::string_view line_;
  size_t pos_ = 0;
};

// Where each COLMAP camera parameter goes; kZero must be 0 (a parameter
// CameraIntrinsics cannot hold).
enum class Param { kF, kFx, kFy, kCx, kCy, kK1, kK2, kP1, kP2, kK3, kZero };

struct CameraModelLayout {
  std::string_view name;
  std::vector<Param> params;  // in COLMAP's order
};

const CameraModelLayout* find_camera_model(std::string_view name) {
  using P = Param;
  static const std::vector<CameraModelLayout> kModels = {
      {"SIMPLE_PINHOLE", {P::kF, P::kCx, P::kCy}},
      {"PINHOLE", {P::kFx, P::kFy, P::kCx, P::kCy}},
      {"SIMPLE_RADIAL", {P::kF, P::kCx, P::kCy, P::kK1}},
      {"RADIAL", {P::kF, P::kCx, P::kCy, P::kK1, P::kK2}},
      {"OPENCV",
       {P::kFx, P::kFy, P::kCx, P::kCy, P::kK1, P::kK2, P::kP1, P::kP2}},
      {"FULL_OPENCV",
       {P::kFx, P::kFy, P::kCx, P::kCy, P::kK1, P::kK2, P::kP1, P::kP2, P::kK3,
        P::kZero, P::kZero, P::kZero}}};
  for (const CameraModelLayout& model : kModels) {
    if (model.name == name) return &model;
  }
  return nullptr;
}

void set_param(Param param, double value, CameraIntrinsics& c,
               const TextFile& file) {
  // clang-format off
  switch (param) {
    case Param::kF: c.fx = c.fy = value; break;
    case Param::kFx: c.fx = value; break;
    case Param::kFy: c.fy = value; break;
    case Param::kCx: c.cx = value - kColmapPixelShift; break;
    case Param::kCy: c.cy = value - kColmapPixelShift; break;
    case Param::kK1: c.k1 = value; break;
    case Param::kK2: c.k2 = value; break;
    case Param::kP1: c.p1 = value; break;
    case Param::kP2: c.p2 = value; break;
    case Param::kK3: c.k3 = value; break;
    case Param::kZero:
      if (value != 0) file.fail("rational distortion (k4..k6) unsupported");
      break;
  }
  // clang-format on
}

CameraIntrinsics parse_camera(Fields& fields, const TextFile& file) {
  const std::string_view name = fields.word("MODEL");
  const CameraModelLayout* model = find_camera_model(name);
  if (!model) {
    file.fail("unsupported camera model '" + std::string(name) + "'");
  }
  constexpr int64_t kMaxSide = std::numeric_limits<int>::max();
  CameraIntrinsics camera;
  camera.width = static_cast<int>(fields.integer("WIDTH", 1, kMaxSide));
  camera.height = static_cast<int>(fields.integer("HEIGHT", 1, kMaxSide));
  for (Param param : model->params) {
    set_param(param, fields.real("camera parameter"), camera, file);
  }
  fields.expect_end();
  return camera;
}

// Camera index in Model::cameras by COLMAP CAMERA_ID.
std::map<int64_t, int> read_cameras(const std::string& path, Model& model) {
  TextFile file(path);
  std::map<int64_t, int> index;
  std::string line;
  while (file.next_data_line(line)) {
    Fields fields(file, line);
    const int64_t id = fields.integer("CAMERA_ID");
    CameraIntrinsics camera = parse_camera(fields, file);
    if (!index.emplace(id, static_cast<int>(model.cameras.size())).second) {
      file.fail("duplicate CAMERA_ID " + std::to_string(id));
    }
    model.cameras.push_back({std::to_string(id), std::move(camera)});
  }
  return index;
}

// COLMAP writes -1 for "no point"; valid ids start at 1.
int64_t parse_point_id(Fields& fields, const TextFile& file) {
  const int64_t id = fields.integer("POINT3D_ID");
  if (id == -1) return -1;
  if (id < 1) file.fail("bad POINT3D_ID " + std::to_string(id));
  return id - 1;
}

void parse_points2d(const TextFile& file, std::string_view line,
                    ModelImage& image) {
  Fields fields(file, line);
  while (!fields.at_end()) {
    const double x = fields.real("X");
    const double y = fields.real("Y");
    image.keypoints.push_back({x - kColmapPixelShift, y - kColmapPixelShift});
    image.point_ids.push_back(parse_point_id(fields, file));
  }
}

std::array<double, 3> centre_of(const ModelImage& image) {
  const auto& [w, x, y, z] = image.qvec;
  const Eigen::Quaterniond q(w, x, y, z);
  const Eigen::Vector3d t(image.tvec[0], image.tvec[1], image.tvec[2]);
  const Eigen::Vector3d c = -(q.normalized().conjugate() * t);
  return {c.x(), c.y(), c.z()};
}

ModelImage parse_image(Fields& fields, const TextFile& file,
                       const std::map<int64_t, int>& cameras) {
  ModelImage image;
  for (double& v : image.qvec) v = fields.real("quaternion");
  for (double& v : image.tvec) v = fields.real("translation");
  const int64_t camera_id = fields.integer("CAMERA_ID");
  const auto camera = cameras.find(camera_id);
  if (camera == cameras.end()) {
    file.fail("unknown CAMERA_ID " + std::to_string(camera_id));
  }
  image.camera = camera->second;
  image.id = fields.rest();
  if (image.id.empty()) file.fail("missing NAME");
  image.centre = centre_of(image);
  return image;
}

struct ImageTable {
  std::map<int64_t, int> index;     // by COLMAP IMAGE_ID
  std::vector<int> points2d_lines;  // per image, for messages
};

ImageTable read_images(const std::string& path,
                       const std::map<int64_t, int>& cameras, Model& model) {
  TextFile file(path);
  ImageTable table;
  std::string line;
  while (file.next_data_line(line)) {
    Fields fields(file, line);
    const int64_t id = fields.integer("IMAGE_ID");
    ModelImage image = parse_image(fields, file, cameras);
    if (!table.index.emplace(id, static_cast<int>(model.images.size()))
             .second) {
      file.fail("duplicate IMAGE_ID " + std::to_string(id));
    }
    // The POINTS2D line follows at once and may be empty: no comment skip.
    if (!file.next_line(line)) file.fail("missing POINTS2D line");
    parse_points2d(file, line, image);
    table.points2d_lines.push_back(file.line_number());
    model.images.push_back(std::move(image));
  }
  return table;
}

// One (IMAGE_ID, POINT2D_IDX) pair of a track, as indices, checked against
// the image's keypoints and the point they say they observe.
std::pair<int, int> parse_observation(Fields& fields, const TextFile& file,
                                      const ImageTable& images,
                                      const Model& model, int64_t point_id) {
  const int64_t image_id = fields.integer("IMAGE_ID");
  const auto found = images.index.find(image_id);
  if (found == images.index.end()) {
    file.fail("unknown IMAGE_ID " + std::to_string(image_id) + " in track");
  }
  const ModelImage& image = model.images[found->second];
  const int64_t keypoint = fields.integer("POINT2D_IDX");
  if (keypoint < 0 ||
      keypoint >= static_cast<int64_t>(image.keypoints.size())) {
    file.fail("POINT2D_IDX " + std::to_string(keypoint) +
              " out of range for IMAGE_ID " + std::to_string(image_id));
  }
  if (image.point_ids[keypoint] != point_id) {
    file.fail("keypoint " + std::to_string(keypoint) + " of IMAGE_ID " +
              std::to_string(image_id) + " observes another point");
  }
  return {found->second, static_cast<int>(keypoint)};
}

ModelPoint parse_point(Fields& fields, const TextFile& file,
                       const ImageTable& images, const Model& model) {
  ModelPoint point;
  point.id = parse_point_id(fields, file);
  if (point.id < 0) file.fail("bad POINT3D_ID -1");
  for (double& v : point.xyz) v = fields.real("coordinate");
  for (uint8_t& v : point.rgb) {
    v = static_cast<uint8_t>(fields.integer("colour", 0, 255));
  }
  point.error_px = fields.real("ERROR");
  while (!fields.at_end()) {
    point.track.push_back(
        parse_observation(fields, file, images, model, point.id));
  }
  return point;
}

void read_points(const std::string& path, const ImageTable& images,
                 Model& model) {
  TextFile file(path);
  std::set<int64_t> ids;
  std::string line;
  while (file.next_data_line(line)) {
    Fields fields(file, line);
    ModelPoint point = parse_point(fields, file, images, model);
    if (!ids.insert(point.id).second) {
      file.fail("duplicate POINT3D_ID " + std::to_string(point.id + 1));
    }
    model.points.push_back(std::move(point));
  }
}

// Every observation in images.txt must name a point of points3D.txt; the
// other direction parse_observation checks.
void check_observed_points(const Model& model, const ImageTable& images,
                           const std::string& images_path) {
  std::set<int64_t> ids;
  for (const ModelPoint& point : model.points) ids.insert(point.id);
  for (size_t i = 0; i < model.images.size(); ++i) {
    for (int64_t id : model.images[i].point_ids) {
      if (id >= 0 && !ids.count(id)) {
        throw std::runtime_error(images_path + ":" +
                                 std::to_string(images.points2d_lines[i]) +
                                 ": POINT3D_ID " + std::to_string(id + 1) +
                                 " is not in points3D.txt");
      }
    }
  }
}

double mean_reprojection(const Model& model) {
  double sum = 0;
  size_t count = 0;
  for (const ModelPoint& point : model.points) {
    sum += point.error_px * static_cast<double>(point.track.size());
    count += point.track.size();
  }
  return count ? sum / static_cast<double>(count) : 0;
}

}  // namespace

void write_colmap_text(const Model& model, const std::string& dir) {
  std::filesystem::create_directories(dir);
  for (const ColmapTextFile file :
       {ColmapTextFile::kCameras, ColmapTextFile::kImages,
        ColmapTextFile::kPoints})
    write_text_file(dir + "/" + colmap_file_name(file), [&](std::ostream& out) {
      write_colmap_text(model, file, out);
    });
}

const char* colmap_file_name(ColmapTextFile file) {
  switch (file) {
    case ColmapTextFile::kCameras:
      return "cameras.txt";
    case ColmapTextFile::kImages:
      return "images.txt";
    case ColmapTextFile::kPoints:
      return "points3D.txt";
  }
  return "?";
}

void write_colmap_text(const Model& model, ColmapTextFile file,
                       std::ostream& out) {
  switch (file) {
    case ColmapTextFile::kCameras:
      return write_cameras(model, out);
    case ColmapTextFile::kImages:
      return write_images(model, out);
    case ColmapTextFile::kPoints:
      return write_points(model, out);
  }
}

Model read_colmap_text(const std::string& dir) {
  Model model;
  const std::map<int64_t, int> cameras =
      read_cameras(dir + "/cameras.txt", model);
  const ImageTable images = read_images(dir + "/images.txt", cameras, model);
  read_points(dir + "/points3D.txt", images, model);
  check_observed_points(model, images, dir + "/images.txt");
  model.mean_reprojection_px = mean_reprojection(model);
  return model;
}

void write_points_ply(const Model& model, const std::string& path) {
  std::vector<ColoredPoint> points;
  points.reserve(model.points.size());
  for (const ModelPoint& point : model.points) {
    points.push_back({to_float(point.xyz[0]), to_float(point.xyz[1]),
                      to_float(point.xyz[2]), point.rgb[0], point.rgb[1],
                      point.rgb[2]});
  }
  write_ply(path, points,
            std::string("arscout sparse model, world frame ") +
                (model.geo_registered ? "ENU" : "local"));
}

void write_geo_csv(const Model& model, const std::string& path) {
  write_text_file(path, [&](std::ostream& out) { write_geo_csv(model, out); });
}

void write_geo_csv(const Model& model, std::ostream& out) {
  out << "image,latitude,longitude,altitude\n";
  out << std::fixed;
  for (const ModelImage& image : model.images) {
    if (!image.geodetic) continue;
    out << image.id << ',' << std::setprecision(9) << image.geodetic->lat << ','
        << image.geodetic->lon << ',' << std::setprecision(3)
        << image.geodetic->alt << '\n';
  }
}

}  // namespace arscout::engine
