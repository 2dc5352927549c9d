#include "arscout/engine/calibration.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <stdexcept>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace arscout::engine {
namespace {

// Phone photos are 12 MP and more; findChessboardCorners on the full image
// takes seconds each, so the board is found on a copy at most this wide and
// the corners are then refined on the full image.
constexpr int kDetectMaxSide = 1600;
constexpr int kMinViews = 3;

// --- calibrate_chessboard ---------------------------------------------------

using Corners = std::vector<cv::Point2f>;

double min_corner_spacing(const Corners& corners, BoardSize board) {
  double best = std::numeric_limits<double>::max();
  for (int r = 0; r < board.rows; ++r)
    for (int c = 0; c + 1 < board.cols; ++c)
      best = std::min<double>(best, cv::norm(corners[r * board.cols + c + 1] -
                                             corners[r * board.cols + c]));
  return best;
}

// The inner corners to sub-pixel accuracy, or nullopt when the whole board is
// not in the image.
std::optional<Corners> find_corners(const cv::Mat& gray, BoardSize board) {
  const cv::Size pattern(board.cols, board.rows);
  double scale = std::min(1.0, static_cast<double>(kDetectMaxSide) /
                                   std::max(gray.cols, gray.rows));
  cv::Mat small = gray;
  if (scale < 1.0)
    cv::resize(gray, small, cv::Size(), scale, scale, cv::INTER_AREA);
  Corners corners;
  const int flags = cv::CALIB_CB_ADAPTIVE_THRESH |
                    cv::CALIB_CB_NORMALIZE_IMAGE | cv::CALIB_CB_FAST_CHECK;
  if (!cv::findChessboardCorners(small, pattern, corners, flags))
    return std::nullopt;
  // Back to full-size pixels; pixel centres sit at integers in both images.
  for (auto& p : corners)
    p = (p + cv::Point2f(0.5f, 0.5f)) / scale - cv::Point2f(0.5f, 0.5f);
  // The refinement window must stay inside the squares around each corner,
  // or it locks onto the neighbouring corners' edges.
  int half = std::clamp(
      static_cast<int>(std::lround(min_corner_spacing(corners, board) / 3)), 2,
      11);
  cv::cornerSubPix(
      gray, corners, cv::Size(half, half), cv::Size(-1, -1),
      cv::TermCriteria(cv::TermCriteria::EPS | cv::TermCriteria::COUNT, 50,
                       1e-3));
  return corners;
}

std::string size_text(cv::Size size) {
  return std::to_string(size.width) + "x" + std::to_string(size.height);
}

// One set of intrinsics holds for one image size only.
void check_same_size(const std::string& first_path, cv::Size first,
                     const std::string& path, cv::Size size) {
  if (size != first)
    throw std::runtime_error("images differ in size: " + first_path + " is " +
                             size_text(first) + ", " + path + " is " +
                             size_text(size) +
                             "; calibrate one camera at one resolution");
}

// Reads every image and finds the board; reports each image as it goes.
std::vector<Corners> find_views(const std::vector<std::string>& paths,
                                BoardSize board, cv::Size* image_size,
                                std::vector<std::string>* rejected,
                                const ImageStatusCallback& on_image) {
  std::vector<Corners> views;
  std::string first_path;
  auto report = [&](const std::string& path, const std::string& problem) {
    if (rejected && !problem.empty())
      rejected->push_back(path + ": " + problem);
    if (on_image) on_image(path, problem);
  };
  for (const auto& path : paths) {
    // Intrinsics belong to the sensor, so images are taken as stored, not
    // turned by their EXIF orientation.
    cv::Mat gray =
        cv::imread(path, cv::IMREAD_GRAYSCALE | cv::IMREAD_IGNORE_ORIENTATION);
    if (gray.empty()) {
      report(path, "not a readable image");
      continue;
    }
    if (first_path.empty()) {
      first_path = path;
      *image_size = gray.size();
    }
    check_same_size(first_path, *image_size, path, gray.size());
    auto corners = find_corners(gray, board);
    if (!corners) {
      report(path, "chessboard with " + size_text({board.cols, board.rows}) +
                       " inner corners not found (the whole board must be "
                       "visible)");
      continue;
    }
    views.push_back(std::move(*corners));
    report(path, "");
  }
  return views;
}

std::vector<cv::Point3f> board_points(BoardSize board, double square_m) {
  std::vector<cv::Point3f> points;
  for (int r = 0; r < board.rows; ++r)
    for (int c = 0; c < board.cols; ++c)
      points.emplace_back(static_cast<float>(c * square_m),
                          static_cast<float>(r * square_m), 0.0f);
  return points;
}

CameraCalibration fit(const std::vector<Corners>& image_points, BoardSize board,
                      double square_m, cv::Size image_size) {
  std::vector<std::vector<cv::Point3f>> object_points(
      image_points.size(), board_points(board, square_m));
  cv::Mat k, d;
  std::vector<cv::Mat> rvecs, tvecs;
  // k3 is left at 0: with the dozen views a scout takes it is barely
  // constrained and trades off against k1, k2 and the focal length.
  double rms = cv::calibrateCamera(
      object_points, image_points, image_size, k, d, rvecs, tvecs,
      cv::CALIB_FIX_K3,
      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 100,
                       std::numeric_limits<double>::epsilon()));
  CameraCalibration c;
  c.width = image_size.width;
  c.height = image_size.height;
  c.fx = k.at<double>(0, 0);
  c.fy = k.at<double>(1, 1);
  c.cx = k.at<double>(0, 2);
  c.cy = k.at<double>(1, 2);
  const double* dist = d.ptr<double>();
  c.k1 = dist[0];
  c.k2 = dist[1];
  c.p1 = dist[2];
  c.p2 = dist[3];
  c.k3 = dist[4];
  c.rms_px = rms;
  c.images_used = static_cast<int>(image_points.size());
  return c;
}

}  // namespace

std::optional<BoardSize> parse_board_size(const std::string& text) {
  auto x = text.find_first_of("xX");
  if (x == std::string::npos) return std::nullopt;
  auto parse = [](const std::string& s) -> std::optional<int> {
    if (s.empty() || s.size() > 3 ||
        !std::all_of(s.begin(), s.end(), [](char ch) {
          return std::isdigit(static_cast<unsigned char>(ch));
        }))
      return std::nullopt;
    int v = std::atoi(s.c_str());
    if (v < 3 || v > 100) return std::nullopt;
    return v;
  };
  auto cols = parse(text.substr(0, x));
  auto rows = parse(text.substr(x + 1));
  if (!cols || !rows) return std::nullopt;
  return BoardSize{*cols, *rows};
}

CameraCalibration calibrate_chessboard(
    const std::vector<std::string>& image_paths, BoardSize inner_corners,
    double square_m, std::vector<std::string>* rejected,
    const ImageStatusCallback& on_image) {
  if (inner_corners.cols < 3 || inner_corners.rows < 3)
    throw std::invalid_argument(
        "the chessboard needs at least 3x3 inner corners");
  if (!std::isfinite(square_m) || square_m <= 0)
    throw std::invalid_argument("the square size must be positive metres");
  cv::Size image_size;
  auto views =
      find_views(image_paths, inner_corners, &image_size, rejected, on_image);
  if (views.size() < static_cast<std::size_t>(kMinViews))
    throw std::runtime_error(
        "calibration needs at least " + std::to_string(kMinViews) +
        " images showing the whole chessboard; found it in " +
        std::to_string(views.size()) + " of " +
        std::to_string(image_paths.size()));
  return fit(views, inner_corners, square_m, image_size);
}

}  // namespace arscout::engine
