// Writing a Model in standard formats: the COLMAP text model, binary PLY,
// and the camera table CSV.
#pragma once

#include <string>

#include "arscout/engine/reconstruction.h"

namespace arscout::engine {

// DIR/cameras.txt, images.txt, points3D.txt. Cameras are OPENCV (or
// FULL_OPENCV when k3 is set) in COLMAP's pixel convention (centre of the
// top-left pixel at 0.5, 0.5); the world frame is the model's. Creates DIR.
void write_colmap_text(const Model& model, const std::string& dir);

// Binary little-endian PLY: float x y z, uchar red green blue per point.
void write_points_ply(const Model& model, const std::string& path);

// image,latitude,longitude,altitude for every geo-registered image (an
// empty table, header only, when the model is not geo-registered).
void write_geo_csv(const Model& model, const std::string& path);

}  // namespace arscout::engine
