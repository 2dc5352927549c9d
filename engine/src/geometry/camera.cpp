#include "arscout/engine/camera.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <stdexcept>

namespace arscout::engine {

std::string validate(const CameraIntrinsics& c) {
  if (c.width <= 0 || c.height <= 0) return "image size must be positive";
  for (double v : {c.fx, c.fy, c.cx, c.cy, c.k1, c.k2, c.p1, c.p2, c.k3}) {
    if (!std::isfinite(v)) return "intrinsics must be finite numbers";
  }
  if (c.fx <= 0 || c.fy <= 0) return "focal lengths must be positive";
  if (c.cx < 0 || c.cx > c.width || c.cy < 0 || c.cy > c.height) {
    return "principal point must lie inside the image";
  }
  return "";
}

CameraIntrinsics centred_camera(int width, int height, double focal_px,
                                const std::string& source) {
  CameraIntrinsics c;
  c.width = width;
  c.height = height;
  c.fx = c.fy = focal_px;
  c.cx = (width - 1) / 2.0;
  c.cy = (height - 1) / 2.0;
  c.source = source;
  return c;
}

std::optional<double> focal_px_from_exif(int width, int height,
                                         std::optional<double> focal_35mm,
                                         std::optional<double> focal_mm,
                                         std::optional<double> plane_res,
                                         std::optional<double> plane_unit_mm) {
  const double long_side = std::max(width, height);
  if (focal_35mm && *focal_35mm > 0) return *focal_35mm / 36.0 * long_side;
  if (focal_mm && plane_res && plane_unit_mm && *focal_mm > 0 &&
      *plane_res > 0 && *plane_unit_mm > 0) {
    return *focal_mm * *plane_res / *plane_unit_mm;
  }
  return std::nullopt;
}

CameraIntrinsics guessed_camera(int width, int height) {
  return centred_camera(width, height, 1.2 * std::max(width, height),
                        "estimated");
}

CameraIntrinsics read_k_matrix(const std::string& path, int width, int height) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open");
  double k[9];
  for (double& v : k) {
    if (!(in >> v)) {
      throw std::runtime_error(path + ": expected nine numbers (a 3x3 K)");
    }
  }
  if (k[1] != 0 || k[3] != 0 || k[6] != 0 || k[7] != 0 || k[8] != 1) {
    throw std::runtime_error(
        path + ": not a pinhole K (rows fx 0 cx, 0 fy cy, 0 0 1)");
  }
  CameraIntrinsics c;
  c.width = width;
  c.height = height;
  c.fx = k[0];
  c.fy = k[4];
  c.cx = k[2];
  c.cy = k[5];
  c.source = "calibrated";
  if (std::string problem = validate(c); !problem.empty()) {
    throw std::runtime_error(path + ": " + problem);
  }
  return c;
}

}  // namespace arscout::engine
