// Surfaces (docs/mesh.md): a textured triangle mesh per dense tile, made
// from the filtered dense cloud (points with normals and support), textured
// from the registered photos, and simplified into levels of detail.
//
// The surface is the zero set of an implicit function of the oriented
// points (each point's tangent plane, blended over its neighbours: Kolluri's
// IMLS), sampled on one grid for the whole site and polygonised by marching
// cubes only in cells near points. A tile polygonises the cells whose lowest
// corner lies in it, from the points of its own and its neighbours' columns
// within the blending radius: two tiles compute the same values at the grid
// corners they share, so their meshes meet edge to edge (no seam to close).
//
// Frames: the site frame of the dense cloud (the model's frame; ENU once
// geo-registered). Triangles wind counter-clockwise seen from the side the
// normals point to (the cameras' side).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "arscout/engine/dense_reconstruction.h"
#include "arscout/engine/ply.h"

namespace arscout::engine {

// A triangle mesh with at most one texture atlas.
struct TexturedMesh {
  std::vector<Eigen::Vector3f> positions;
  // Per vertex: a unit normal (empty: none) and a colour (empty: none;
  // the untextured look, and what a renderer without the atlas shows).
  std::vector<Eigen::Vector3f> normals;
  std::vector<std::array<std::uint8_t, 3>> colors;  // RGB
  // Per vertex texture coordinates in [0, 1], origin at the atlas's top
  // left (glTF's convention); empty when there is no atlas.
  std::vector<Eigen::Vector2f> uvs;
  std::vector<std::uint32_t> indices;  // three per triangle
  cv::Mat atlas;                       // CV_8UC3 (BGR); empty: none

  std::size_t triangles() const { return indices.size() / 3; }
  bool empty() const { return indices.empty(); }
};

// One level of detail of a tile: the mesh and its geometric error (metres
// in the site frame: how far its surface may lie from the finest level's;
// 0 for the finest).
struct MeshLevel {
  TexturedMesh mesh;
  double geometric_error = 0;
};

// ---------------------------------------------------------------------------
// Surface from oriented points.

struct SurfaceOptions {
  // Grid step (site units); 0: twice the dense cloud's voxel edge as given
  // to mesh_surface.
  double cell = 0;
  // The implicit function blends the points within this many cells of a
  // grid corner; corners with fewer than min_points there are unknown, and
  // cells with an unknown corner make no triangles (no surface is invented
  // far from the data).
  double radius_cells = 2.0;
  int min_points = 3;
  // Points measured by fewer depth maps are left out (ColoredPoint::
  // support; 0-support points, which are not fused, are kept). Every fused
  // point by default: the blending averages single depths out, and on the
  // block walks confident points alone (3) left 81 % of the surface
  // covered against 90 % (bench/RESULTS.md). Callers pass the cloud
  // without its isolated points (without_isolated_points).
  int min_support = 1;
  // Connected pieces smaller than this area (in squared grid steps: 64 is
  // a patch of 8 x 8 cells, 27 cm square at the block walk's 3.4 cm) are
  // dropped, unless they reach the column's border: a tight cluster of
  // stray points makes a closed blob about the blending radius across.
  double min_piece_area_cells = 64;
  // Triangles whose centre lies farther than this many cells from every
  // point are dropped: the blending carries the surface past the data (a
  // rim where the points end, a bridge over a gap) up to about the cubes
  // around the points, and that surface is guessed, not measured. At most
  // radius_cells; 0: none is dropped.
  double trim_cells = 1.0;
};

// The surface of the cells whose lowest corner lies in the column
// [x0, x1) x [y0, y1) (any z), from `points`, which must hold every point
// within the blending radius of that column (the tile's and its
// neighbours'). The grid is anchored at the origin with step `cell` (the
// options' cell, or 2 * voxel), so neighbouring columns meet edge to edge.
// Vertex colours are the blended points' colours; no atlas. Deterministic.
TexturedMesh mesh_surface(const std::vector<ColoredPoint>& points,
                          const Eigen::Vector2d& column_min,
                          const Eigen::Vector2d& column_max, double voxel,
                          const SurfaceOptions& options = {});

// ---------------------------------------------------------------------------
// Texture.

// A registered photo as the texture's source.
struct TextureView {
  std::string id;
  cv::Mat bgr;  // CV_8UC3, undistorted (a pinhole of K)
  Eigen::Matrix3d K = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  // Optional: the view's depth map (camera z, 0 where unknown), of any
  // size (its intrinsics are K scaled by depth.cols / bgr.cols). It hides
  // what lies behind surfaces the mesh being textured does not hold (the
  // neighbouring tiles', the unmeshed).
  cv::Mat depth;
};

// The dense reconstruction's key views as texture sources (their photos at
// the working resolution, current poses and depth maps), sharing pixels.
std::vector<TextureView> texture_views(
    const std::vector<DenseReconstruction::KeyView>& key_views);

struct TextureOptions {
  // A view textures a face only when it sees it at least this squarely
  // (cosine of the angle between the face's normal and the ray): a scout
  // sees the street's ground at 80 degrees and more, and a grazing view is
  // better than none (the largest footprint wins where there is a choice).
  double min_cos = 0.1;
  // A face is hidden when something is nearer than its depth by more than
  // this share of it (in the mesh's own z-buffer or the view's depth map).
  double occlusion_tolerance = 0.03;
  // The occlusion z-buffer's long side, pixels.
  int raster_long_side = 960;
  // Rounds that give a face its neighbours' view when that view sees it
  // nearly as well (fewer, larger patches: fewer seams).
  int smoothing_rounds = 3;
  // The atlas's longest side; the patches are scaled down together to fit
  // (at most the photos' resolution).
  int max_atlas_side = 4096;
};

// `surface` with texture coordinates and one atlas: each face takes the
// view that sees it largest in pixels (facing it within min_cos, not
// hidden), neighbours' choices are smoothed, faces of one view that touch
// form a patch copied from that photo into the atlas, and each patch's
// colour is levelled by one gain per channel toward the mean of the views
// at its seams. Faces no view sees keep their vertices' colour (a flat
// texel each). Vertices on patch borders are duplicated. When the patches
// cannot fit max_atlas_side at any scale (each keeps a few texels of
// padding), the surface comes back as it was (vertex colours, no atlas).
// Deterministic.
TexturedMesh texture_mesh(const TexturedMesh& surface,
                          const std::vector<TextureView>& views,
                          const TextureOptions& options = {});

// The mesh drawn into a pinhole view: the atlas sampled bilinearly where
// there is one, else the vertices' colours (black where nothing is seen),
// and the depth of the nearest surface (0 where none).
struct MeshRendering {
  cv::Mat bgr;    // CV_8UC3
  cv::Mat depth;  // CV_32F
};
MeshRendering render_mesh(const TexturedMesh& mesh, const Eigen::Matrix3d& K,
                          const Eigen::Matrix3d& R, const Eigen::Vector3d& t,
                          cv::Size size);

// How well the textured surface predicts a photo it was not textured from
// (the paper's "does the model match the view"): for each view, `surface`
// textured from the others and drawn into it; the ZNCC of the grey levels
// over the pixels the surface covers, and their share of the picture.
struct HoldoutScore {
  std::string id;
  double zncc = 0;
  double covered = 0;
};
// `held`: the indices of the views to score (empty: all).
std::vector<HoldoutScore> holdout_scores(
    const TexturedMesh& surface, const std::vector<TextureView>& views,
    const TextureOptions& options = {},
    const std::vector<std::size_t>& held = {});

// ---------------------------------------------------------------------------
// Levels of detail.

// `mesh` (level 0, error 0) and coarser versions of it, each with about a
// quarter of the previous level's triangles (quadric edge collapse through
// meshoptimizer, borders locked so that tiles still meet), at most `levels`
// in all, stopping early when a level would keep fewer than 64 triangles.
// Each level's geometric error is meshoptimizer's reported error in site
// units. Keeps colours, normals and texture coordinates of the kept
// vertices (the atlas is shared by every level).
std::vector<MeshLevel> mesh_levels(const TexturedMesh& mesh, int levels = 3);

// ---------------------------------------------------------------------------
// Bytes.

// A binary glTF 2.0 (GLB) of `mesh`: one mesh, one primitive (triangles;
// POSITION, NORMAL, COLOR_0, TEXCOORD_0 as present), the atlas as an
// embedded JPEG of `jpeg_quality` with a metallic-roughness material that
// is unlit (KHR_materials_unlit: the photos hold the light already).
// With an atlas the vertex colours are written as "_COLOR" instead of
// COLOR_0: glTF multiplies COLOR_0 into the base colour texture, which
// would darken the photos; "_COLOR" is an application attribute that
// renderers leave alone and decode_glb reads back. Colours are RGBA
// normalized bytes (alpha 255), indices 32-bit. Positions are written as
// given (the site frame, z up); a viewer turns them. Throws
// std::invalid_argument for an empty mesh or inconsistent attribute sizes
// (an index past the vertices, an atlas that is not CV_8UC3 or has no
// texture coordinates, a position that is not finite).
std::string encode_glb(const TexturedMesh& mesh, int jpeg_quality = 88);

// The atlas as the JPEG file encode_glb embeds ("" for an empty atlas):
// for GLBs that share one atlas (encode_glb_meshes with it as the image),
// compressed once. Throws std::invalid_argument when it is not CV_8UC3.
std::string encode_atlas_jpeg(const cv::Mat& atlas, int jpeg_quality = 88);

// Reads a GLB written by encode_glb (or any with one indexed triangle
// primitive of float positions; node transforms are not applied). Throws
// std::runtime_error, naming what is wrong, for anything else.
TexturedMesh decode_glb(const std::string& bytes);

// A mesh whose atlas is the image file a GLB embeds (JPEG or PNG) rather
// than pixels: what the exports carry from the stored GLBs into theirs
// without decoding the photos' texture and compressing it again.
struct GlbMesh {
  TexturedMesh mesh;       // its atlas is not read (left empty)
  std::string image;       // the atlas's file; empty: none
  std::string image_mime;  // "image/jpeg" or "image/png"
};

// Where encode_glb_meshes puts the meshes in the glTF's frame.
struct GlbFrame {
  // Positions are written less `offset` (floats keep millimetres near it)
  // and the node's translation adds it back.
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();
  // Turns the site frame (z up) into glTF's (y up): (x, y, z) ->
  // (x, z, -y), applied to positions, normals and the translation, so
  // that a glTF viewer or a 3D Tiles client (which turns y up back into z
  // up) sees the site upright. False: as given, as encode_glb writes.
  bool y_up = false;
};

// One GLB holding `meshes` as the primitives of one mesh (one node), each
// with its own unlit material and its image as given, attributes as
// encode_glb writes them. Throws std::invalid_argument when `meshes` is
// empty or one of them is not what encode_glb takes, or its image is not
// image/jpeg or image/png.
std::string encode_glb_meshes(const std::vector<GlbMesh>& meshes,
                              const GlbFrame& frame = {});

// decode_glb without decoding the atlas: its file as embedded. The same
// errors (the image is not checked).
GlbMesh decode_glb_mesh(const std::string& bytes);

}  // namespace arscout::engine
