#include "arscout/engine/model_io.h"

#include <filesystem>
#include <fstream>
#include <iomanip>
#include <stdexcept>

namespace arscout::engine {
namespace {

std::ofstream open_for_writing(const std::string& path, bool binary = false) {
  std::ofstream out(path, binary ? std::ios::binary : std::ios::out);
  if (!out) throw std::runtime_error(path + ": cannot write");
  out << std::setprecision(17);
  return out;
}

void finish(std::ofstream& out, const std::string& path) {
  out.close();
  if (!out) throw std::runtime_error(path + ": write failed");
}

void write_cameras(const Model& model, const std::string& path) {
  auto out = open_for_writing(path);
  out << "# Camera list with one line of data per camera:\n"
      << "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
      << "# Number of cameras: " << model.cameras.size() << "\n";
  for (size_t i = 0; i < model.cameras.size(); ++i) {
    const CameraIntrinsics& c = model.cameras[i].intrinsics;
    // COLMAP puts the centre of the top-left pixel at (0.5, 0.5).
    out << i + 1 << (c.k3 != 0 ? " FULL_OPENCV " : " OPENCV ") << c.width << ' '
        << c.height << ' ' << c.fx << ' ' << c.fy << ' ' << c.cx + 0.5 << ' '
        << c.cy + 0.5 << ' ' << c.k1 << ' ' << c.k2 << ' ' << c.p1 << ' '
        << c.p2;
    if (c.k3 != 0) out << ' ' << c.k3 << " 0 0 0";
    out << '\n';
  }
  finish(out, path);
}

void write_images(const Model& model, const std::string& path) {
  auto out = open_for_writing(path);
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
      out << image.keypoints[k][0] + 0.5 << ' ' << image.keypoints[k][1] + 0.5
          << ' ' << (image.point_ids[k] >= 0 ? image.point_ids[k] + 1 : -1);
    }
    out << '\n';
  }
  finish(out, path);
}

void write_points(const Model& model, const std::string& path) {
  auto out = open_for_writing(path);
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
  finish(out, path);
}

}  // namespace

void write_colmap_text(const Model& model, const std::string& dir) {
  std::filesystem::create_directories(dir);
  write_cameras(model, dir + "/cameras.txt");
  write_images(model, dir + "/images.txt");
  write_points(model, dir + "/points3D.txt");
}

void write_points_ply(const Model& model, const std::string& path) {
  auto out = open_for_writing(path, true);
  out << "ply\nformat binary_little_endian 1.0\n"
      << "comment arscout sparse model, world frame "
      << (model.geo_registered ? "ENU" : "local") << "\n"
      << "element vertex " << model.points.size() << "\n"
      << "property float x\nproperty float y\nproperty float z\n"
      << "property uchar red\nproperty uchar green\nproperty uchar blue\n"
      << "end_header\n";
  for (const ModelPoint& point : model.points) {
    const float xyz[3] = {static_cast<float>(point.xyz[0]),
                          static_cast<float>(point.xyz[1]),
                          static_cast<float>(point.xyz[2])};
    out.write(reinterpret_cast<const char*>(xyz), sizeof(xyz));
    out.write(reinterpret_cast<const char*>(point.rgb.data()), 3);
  }
  finish(out, path);
}

void write_geo_csv(const Model& model, const std::string& path) {
  auto out = open_for_writing(path);
  out << "image,latitude,longitude,altitude\n";
  out << std::fixed;
  for (const ModelImage& image : model.images) {
    if (!image.geodetic) continue;
    out << image.id << ',' << std::setprecision(9) << image.geodetic->lat << ','
        << image.geodetic->lon << ',' << std::setprecision(3)
        << image.geodetic->alt << '\n';
  }
  finish(out, path);
}

}  // namespace arscout::engine
