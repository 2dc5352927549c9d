#include "arscout/viewer/overlay.h"
#include "arscout/util/error.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "arscout/ingest/image_budget.h"
#include "overlay_meshes.h"

namespace arscout::viewer {
namespace {

// The drawn depth range: the 2nd to 98th percentile, so a few stray points
// do not wash the colours out.
std::pair<float, float> depth_range(const cv::Mat& depth) {
  std::vector<float> drawn;
  for (int y = 0; y < depth.rows; ++y)
    for (int x = 0; x < depth.cols; ++x)
      if (float z = depth.at<float>(y, x); z > 0) drawn.push_back(z);
  if (drawn.empty()) return {0.f, 1.f};
  auto at = [&](double q) {
    auto it =
        drawn.begin() + static_cast<std::ptrdiff_t>(q * (drawn.size() - 1));
    std::nth_element(drawn.begin(), it, drawn.end());
    return *it;
  };
  const float lo = at(0.02), hi = at(0.98);
  return {lo, std::max(hi, lo + 1e-3f)};
}

// Nearest point per output pixel (camera z; 0 where none).
cv::Mat splat_depths(const ImageCamera& camera,
                     const std::vector<engine::ColoredPoint>& points,
                     cv::Size size, double scale, int radius, int min_support) {
  cv::Mat depth = cv::Mat::zeros(size, CV_32F);
  for (const engine::ColoredPoint& p : points) {
    if (!engine::shown_at(p, min_support)) continue;
    const Eigen::Vector3d X(p.x, p.y, p.z);
    const auto pixel = project(camera, X);
    if (!pixel) continue;
    // Pixel centres map as OpenCV's resize maps them.
    const int u =
        static_cast<int>(std::lround((pixel->x() + 0.5) * scale - 0.5));
    const int v =
        static_cast<int>(std::lround((pixel->y() + 0.5) * scale - 0.5));
    if (u < -radius || v < -radius || u >= size.width + radius ||
        v >= size.height + radius)
      continue;
    const float z = static_cast<float>((camera.R * X + camera.t).z());
    for (int y = std::max(0, v - radius);
         y <= std::min(size.height - 1, v + radius); ++y) {
      float* row = depth.ptr<float>(y);
      for (int x = std::max(0, u - radius);
           x <= std::min(size.width - 1, u + radius); ++x)
        if (row[x] == 0 || z < row[x]) row[x] = z;
    }
  }
  return depth;
}

// Splats leave gaps through which farther surfaces would show (the fountain
// seen through itself). A drawn pixel much farther than the nearest point
// around it is such a gap: it is cleared.
void clear_see_through(cv::Mat& depth, int radius) {
  cv::Mat nearest = depth.clone();
  nearest.setTo(std::numeric_limits<float>::max(), depth == 0);
  const int window = 6 * radius + 1;
  cv::erode(nearest, nearest,
            cv::getStructuringElement(cv::MORPH_RECT, {window, window}));
  for (int y = 0; y < depth.rows; ++y) {
    float* row = depth.ptr<float>(y);
    const float* near = nearest.ptr<float>(y);
    for (int x = 0; x < depth.cols; ++x)
      if (row[x] > 1.1f * near[x]) row[x] = 0;
  }
}

// The output image's size and its pixels per camera pixel.
struct OutputFrame {
  cv::Size size;
  double scale = 1;
};

OutputFrame output_frame(const cv::Mat& photo, const ImageCamera& camera,
                         int max_side) {
  if (photo.empty() || camera.intrinsics.width <= 0)
    throw std::invalid_argument("overlay: empty photo or camera");
  const int long_side = std::max(photo.cols, photo.rows);
  const double fit = std::min(1.0, static_cast<double>(max_side) / long_side);
  OutputFrame frame;
  frame.size = cv::Size(static_cast<int>(std::lround(photo.cols * fit)),
                        static_cast<int>(std::lround(photo.rows * fit)));
  // The photo may be stored at another size than the camera was estimated
  // for; pixels scale with it.
  frame.scale = fit * static_cast<double>(photo.cols) / camera.intrinsics.width;
  return frame;
}

// `colours` over `out` at `opacity` where `depth` is positive.
void blend_where_seen(const cv::Mat& colours, const cv::Mat& depth,
                      double opacity, cv::Mat* out) {
  const double a = std::clamp(opacity, 0.0, 1.0);
  for (int y = 0; y < out->rows; ++y)
    for (int x = 0; x < out->cols; ++x)
      if (depth.at<float>(y, x) > 0) {
        cv::Vec3b& o = out->at<cv::Vec3b>(y, x);
        const cv::Vec3b& c = colours.at<cv::Vec3b>(y, x);
        for (int ch = 0; ch < 3; ++ch)
          o[ch] = cv::saturate_cast<uint8_t>(a * c[ch] + (1 - a) * o[ch]);
      }
}

// The camera's pinhole in output pixels (pixel centres map as OpenCV's
// resize maps them).
Eigen::Matrix3d output_pinhole(const engine::CameraIntrinsics& k,
                               double scale) {
  Eigen::Matrix3d K;
  K << k.fx * scale, 0, (k.cx + 0.5) * scale - 0.5,  //
      0, k.fy * scale, (k.cy + 0.5) * scale - 0.5,   //
      0, 0, 1;
  return K;
}

// The camera's focal length in output pixels: what turns a surface's
// geometric error into pixels.
double output_focal(const cv::Mat& photo, const ImageCamera& camera,
                    int max_side) {
  return output_frame(photo, camera, max_side).scale * camera.intrinsics.fx;
}

bool has_distortion(const engine::CameraIntrinsics& k) {
  return k.k1 != 0 || k.k2 != 0 || k.k3 != 0 || k.p1 != 0 || k.p2 != 0;
}

// `layer`'s pixels where it is nearer than `*drawn` (or *drawn has none).
void keep_nearest(const engine::MeshRendering& layer,
                  engine::MeshRendering* drawn) {
  for (int y = 0; y < drawn->depth.rows; ++y) {
    const float* near = layer.depth.ptr<float>(y);
    float* depth = drawn->depth.ptr<float>(y);
    for (int x = 0; x < drawn->depth.cols; ++x)
      if (near[x] > 0 && (depth[x] == 0 || near[x] < depth[x])) {
        depth[x] = near[x];
        drawn->bgr.at<cv::Vec3b>(y, x) = layer.bgr.at<cv::Vec3b>(y, x);
      }
  }
}

// The pinhole rendering `pinhole` (intrinsics K) as the lens sees it: each
// output pixel takes the rendering's pixel its undistorted ray hits.
engine::MeshRendering distort(const engine::MeshRendering& pinhole,
                              const engine::CameraIntrinsics& k,
                              const Eigen::Matrix3d& K, double scale) {
  const cv::Size size = pinhole.bgr.size();
  std::vector<cv::Point2f> pixels;
  pixels.reserve(static_cast<std::size_t>(size.area()));
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x)  // in the camera's own pixels
      pixels.emplace_back(static_cast<float>((x + 0.5) / scale - 0.5),
                          static_cast<float>((y + 0.5) / scale - 0.5));
  const cv::Matx33d lens(k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
  const cv::Matx33d out(K(0, 0), 0, K(0, 2), 0, K(1, 1), K(1, 2), 0, 0, 1);
  std::vector<cv::Point2f> rays;
  cv::undistortPoints(pixels, rays, lens,
                      std::vector<double>{k.k1, k.k2, k.p1, k.p2, k.k3},
                      cv::noArray(), out);
  const cv::Mat map = cv::Mat(rays, /*copyData=*/false).reshape(2, size.height);
  engine::MeshRendering lensed;
  cv::remap(pinhole.bgr, lensed.bgr, map, cv::noArray(), cv::INTER_LINEAR);
  cv::remap(pinhole.depth, lensed.depth, map, cv::noArray(), cv::INTER_NEAREST);
  return lensed;
}

}  // namespace

std::optional<Eigen::Vector2d> project(const ImageCamera& camera,
                                       const Eigen::Vector3d& X) {
  const Eigen::Vector3d c = camera.R * X + camera.t;
  if (c.z() <= 1e-9) return std::nullopt;
  const engine::CameraIntrinsics& k = camera.intrinsics;
  const double x = c.x() / c.z(), y = c.y() / c.z();
  const double r2 = x * x + y * y;
  const double radial = 1 + r2 * (k.k1 + r2 * (k.k2 + r2 * k.k3));
  const double xd = x * radial + 2 * k.p1 * x * y + k.p2 * (r2 + 2 * x * x);
  const double yd = y * radial + k.p1 * (r2 + 2 * y * y) + 2 * k.p2 * x * y;
  return Eigen::Vector2d(k.fx * xd + k.cx, k.fy * yd + k.cy);
}

cv::Mat draw_overlay(const cv::Mat& photo, const ImageCamera& camera,
                     const std::vector<engine::ColoredPoint>& points,
                     const OverlayOptions& options) {
  const OutputFrame frame = output_frame(photo, camera, options.max_side);
  const cv::Size size = frame.size;
  const double scale = frame.scale;
  cv::Mat out;
  cv::resize(photo, out, size, 0, 0, cv::INTER_AREA);
  const int radius = options.radius >= 0
                         ? options.radius
                         : std::max(1, std::max(size.width, size.height) / 900);
  cv::Mat depth =
      splat_depths(camera, points, size, scale, radius, options.min_support);
  clear_see_through(depth, radius);
  const auto [near, far] = depth_range(depth);
  cv::Mat level(size, CV_8U, cv::Scalar(0));
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x)
      if (float z = depth.at<float>(y, x); z > 0)
        // Turbo's ends are nearly black: use its blue-to-red middle.
        level.at<uint8_t>(y, x) = cv::saturate_cast<uint8_t>(
            30 + 210.0 * (far - std::clamp(z, near, far)) / (far - near));
  cv::Mat colours;
  cv::applyColorMap(level, colours, cv::COLORMAP_TURBO);
  blend_where_seen(colours, depth, options.opacity, &out);
  return out;
}

cv::Mat draw_mesh_overlay(const cv::Mat& photo, const ImageCamera& camera,
                          const std::vector<engine::TexturedMesh>& meshes,
                          const OverlayOptions& options) {
  const OutputFrame frame = output_frame(photo, camera, options.max_side);
  cv::Mat out;
  cv::resize(photo, out, frame.size, 0, 0, cv::INTER_AREA);
  const Eigen::Matrix3d K = output_pinhole(camera.intrinsics, frame.scale);
  engine::MeshRendering drawn;
  drawn.bgr = cv::Mat::zeros(frame.size, CV_8UC3);
  drawn.depth = cv::Mat::zeros(frame.size, CV_32F);
  for (const engine::TexturedMesh& mesh : meshes)
    keep_nearest(engine::render_mesh(mesh, K, camera.R, camera.t, frame.size),
                 &drawn);
  if (has_distortion(camera.intrinsics))
    drawn = distort(drawn, camera.intrinsics, K, frame.scale);
  blend_where_seen(drawn.bgr, drawn.depth, options.opacity, &out);
  return out;
}

std::string overlay_jpeg(db::Store& store, const std::string& capture,
                         const OverlayOptions& options) {
  const auto doc = store.get("/captures/" + capture);
  if (!doc)
    throw util::Error(util::ErrorKind::kNotFound, "no capture " + capture);
  const std::string site = doc->attrs.value("site", "");
  if (site.empty() || !doc->blobs.count("image"))
    throw util::Error(util::ErrorKind::kNotFound,
                      "capture " + capture + " is not in a site yet");
  const SiteModel model = load_site_model(store, site);
  const auto camera = image_camera(model, capture);
  if (!camera)
    throw util::Error(util::ErrorKind::kNotFound,
                      "capture " + capture + " is not registered in site " +
                          site + "'s model (version " +
                          std::to_string(model.version) + ")");
  const std::string bytes = store.get_blob(doc->blobs.at("image"));
  std::string why;
  const cv::Mat photo = ingest::decode_within_budget(
      bytes,
      // As the engine reads it: its poses are for the pixels as stored.
      cv::IMREAD_COLOR | cv::IMREAD_IGNORE_ORIENTATION, &why);
  if (photo.empty())
    throw util::Error(util::ErrorKind::kInternal,
                      "the photo of capture " + capture + ": " + why);
  const cv::Mat drawn =
      options.draw == OverlayDraw::kMesh
          ? draw_mesh_overlay(
                photo, *camera,
                meshes_seen_by(store, model, *camera,
                               output_focal(photo, *camera, options.max_side)),
                options)
          : draw_overlay(photo, *camera,
                         load_cloud(store, model, options.cloud), options);
  std::vector<uchar> jpeg;
  cv::imencode(".jpg", drawn, jpeg, {cv::IMWRITE_JPEG_QUALITY, 88});
  return std::string(jpeg.begin(), jpeg.end());
}

}  // namespace arscout::viewer
