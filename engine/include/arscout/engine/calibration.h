// Camera intrinsics for the reconstruction (the paper's section 3.1): a scout
// photographs a printed chessboard target from several angles and the
// pinhole model with radial-tangential distortion is fitted to the corners.
// The result is stored as the camera document /cameras/{id} (docs/api.md,
// `PUT /v1/cameras/{id}`); captures name it in their `camera` field.
//
// Part of the engine (OpenCV's calib3d fits the model), but this header
// deliberately uses no OpenCV types: `arscout calibrate` includes it without
// OpenCV's include paths.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "arscout/documents/camera.h"

namespace arscout::engine {

// The result of a calibration is a camera document's form,
// documents::Camera (with rms_px and images_used set); documents::to_json
// writes it and documents::validate_camera checks one sent to the API.
using CameraCalibration = documents::Camera;

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

}  // namespace arscout::engine
