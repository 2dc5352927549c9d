// A Model in standard formats: the COLMAP text model (written and read),
// binary PLY and the camera table CSV (written).
#pragma once

#include <ostream>
#include <string>

#include "arscout/engine/model.h"

namespace arscout::engine {

// DIR/cameras.txt, images.txt, points3D.txt. Cameras are OPENCV (or
// FULL_OPENCV when k3 is set) in COLMAP's pixel convention (centre of the
// top-left pixel at 0.5, 0.5); the world frame is the model's. Creates DIR.
void write_colmap_text(const Model& model, const std::string& dir);

// One of the COLMAP text model's three files, its name, and its text
// written to a stream (what write_colmap_text puts in each file).
enum class ColmapTextFile { kCameras, kImages, kPoints };
const char* colmap_file_name(ColmapTextFile file);
void write_colmap_text(const Model& model, ColmapTextFile file,
                       std::ostream& out);

// The inverse of write_colmap_text: DIR/cameras.txt, images.txt and
// points3D.txt as a Model, in file order. Also reads models written by
// COLMAP itself whose cameras are SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL,
// RADIAL, OPENCV or FULL_OPENCV (with k4 = k5 = k6 = 0); COLMAP ids need not
// be consecutive. What the files do not hold is left at its default:
// geo_registered, enu_origin, image geodetic and camera intrinsics source.
// ModelCamera::id is the COLMAP CAMERA_ID as text; ModelImage::id is NAME;
// ModelPoint::id and ModelImage::point_ids are POINT3D_ID - 1 (as written).
// Principal points and keypoints are moved back by the writer's 0.5 pixel
// (exact to the last bit for all but a few values straddling a power of
// two); centres are computed from the poses, mean_reprojection_px from the
// points' errors weighted by track length.
//
// Throws std::runtime_error("PATH:LINE: what") for a missing or malformed
// line, an unsupported camera model, duplicate ids, an unknown camera id in
// images.txt, an unknown image id or a keypoint index out of range in a
// track, and observations that disagree between images.txt and
// points3D.txt; "PATH: cannot read" when a file is missing.
Model read_colmap_text(const std::string& dir);

// Binary little-endian PLY (encode_ply's layout: float x y z, uchar red
// green blue per point; coordinates beyond float's range become infinite),
// written atomically as by write_ply. Its comment names the world frame.
void write_points_ply(const Model& model, const std::string& path);

// image,latitude,longitude,altitude for every geo-registered image (an
// empty table, header only, when the model is not geo-registered).
void write_geo_csv(const Model& model, const std::string& path);
void write_geo_csv(const Model& model, std::ostream& out);

}  // namespace arscout::engine
