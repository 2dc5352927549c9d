// Camera intrinsics for the reconstruction (the paper's section 3.1): a scout
// photographs a printed chessboard target from several angles and the
// pinhole model with radial-tangential distortion is fitted to the corners.
// The result is stored as the camera document /cameras/{id} (docs/api.md,
// `PUT /v1/cameras/{id}`); captures name it in their `camera` field.
//
// This header deliberately uses no OpenCV types: the `arscout` executable and
// the HTTP layer include it without OpenCV's include paths.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace arscout::ingest {

using Json = nlohmann::json;

// Intrinsics in pixels of one camera at one image size. Pixel centres are at
// integer coordinates (OpenCV's convention), so cx = (width - 1) / 2 is the
// exact centre.
struct CameraCalibration {
  int width = 0;
  int height = 0;
  double fx = 0;
  double fy = 0;
  double cx = 0;
  double cy = 0;
  // Brown-Conrady coefficients in OpenCV's order.
  double k1 = 0;
  double k2 = 0;
  double p1 = 0;
  double p2 = 0;
  double k3 = 0;
  std::string source = "calibrated";  // calibrated | exif | estimated
  double rms_px = 0;    // RMS reprojection error of the fit, pixels
  int images_used = 0;  // views with the board found
};

// The camera document's attributes: {"fx", "fy", "cx", "cy", "width",
// "height", "distortion": [k1, k2, p1, p2, k3], "source", "rms_px",
// "images_used"}.
Json to_json(const CameraCalibration& calibration);

// Checks a camera document's attributes; "" when valid, else a message that
// names the first bad field. Required: fx, fy (positive finite), width,
// height (positive whole numbers), cx, cy (inside the image: 0 <= cx <=
// width, 0 <= cy <= height), source (calibrated, exif or estimated).
// Optional: distortion (an array of 0 to 8 finite numbers), rms_px (finite,
// >= 0), images_used (a whole number >= 0). Other fields are allowed.
std::string validate_camera_json(const Json& camera);

// Inner corners of a chessboard: a board of 10 x 7 squares has 9 x 6.
struct BoardSize {
  int cols = 0;
  int rows = 0;
};

// Parses "COLSxROWS" (e.g. "9x6"); nullopt unless both are whole numbers in
// [3, 100].
std::optional<BoardSize> parse_board_size(const std::string& text);

// Called once per image, in order, as soon as it was looked at: `problem` is
// empty when the board was found, else why the image is not used.
using ImageStatusCallback =
    std::function<void(const std::string& path, const std::string& problem)>;

// Calibrates from photos of a chessboard with `inner_corners` inner corners
// and squares of `square_m` metres (the scale does not change the
// intrinsics, only the poses). Images that cannot be read or do not show the
// whole board are skipped and listed in *rejected (if given) as
// "PATH: REASON". Throws std::invalid_argument for a board below 3 x 3 or a
// square size that is not positive, and std::runtime_error when the images
// differ in size or fewer than 3 show the board.
CameraCalibration calibrate_chessboard(
    const std::vector<std::string>& image_paths, BoardSize inner_corners,
    double square_m, std::vector<std::string>* rejected,
    const ImageStatusCallback& on_image = {});

}  // namespace arscout::ingest
