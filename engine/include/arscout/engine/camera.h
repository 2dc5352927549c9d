// Camera intrinsics as the engine uses them: a pinhole with radial and
// tangential distortion (OpenCV's Brown-Conrady order), in pixels of the
// original photo, pixel centres at integer coordinates (OpenCV's convention).
//
// Where intrinsics come from, best first: a calibration (the camera
// document), the EXIF focal length (35 mm equivalent, or the focal length in
// mm with the focal-plane resolution), or a guess of 1.2 x the long side (as
// COLMAP does). Whatever the source, bundle adjustment may refine them; see
// ReconstructionOptions::refine_intrinsics.
#pragma once

#include <optional>
#include <string>

#include "arscout/documents/camera.h"

namespace arscout::engine {

// The camera document's form (documents/camera.h): one struct for the
// camera the API stores, the engine refines and the model publishes.
using CameraIntrinsics = documents::Camera;

// "" when usable, else what is wrong (sizes, focal lengths, principal point
// outside the image, non-finite numbers).
std::string validate(const CameraIntrinsics& camera);

// A distortion-free camera whose focal length is `focal_px` and whose
// principal point is the image centre.
CameraIntrinsics centred_camera(int width, int height, double focal_px,
                                const std::string& source);

// Focal length in pixels from EXIF: the 35 mm equivalent (36 mm film width
// across the long side), else focal length in mm times the focal-plane
// resolution (pixels per `unit_mm`). nullopt when neither is usable.
std::optional<double> focal_px_from_exif(int width, int height,
                                         std::optional<double> focal_35mm,
                                         std::optional<double> focal_mm,
                                         std::optional<double> plane_res,
                                         std::optional<double> plane_unit_mm);

// The guess used when nothing is known: 1.2 x the long side.
CameraIntrinsics guessed_camera(int width, int height);

// Reads a 3x3 K as in the Strecha `images/K.txt` (nine numbers, row major;
// anything after them ignored) for photos of `width` x `height`. Throws
// std::runtime_error naming the file when it does not hold a usable K.
CameraIntrinsics read_k_matrix(const std::string& path, int width, int height);

}  // namespace arscout::engine
