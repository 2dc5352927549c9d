#include "mesh/atlas.h"
#include "mesh/image_sample.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <unordered_map>

#include <opencv2/imgproc.hpp>

namespace arscout::engine::mesh {
namespace {

constexpr int kPadding = 2;  // texels around each patch, against bleeding

struct Patch {
  int view = -1;  // -1: untextured faces
  std::vector<std::uint32_t> faces;
  std::vector<std::uint32_t> vertices;  // mesh vertices, first use order
  std::vector<Eigen::Vector2d> pixels;  // their projections (photo pixels)
  cv::Rect source;                      // in the photo, padded
  cv::Rect target;                      // in the atlas
  cv::Vec3d gain{1, 1, 1};              // colour levelling, BGR
};

// Faces of one label joined through shared edges (the untextured too: a
// flat texel of their mean colour each such patch).
std::vector<Patch> make_patches(
    const std::vector<int>& labels,
    const std::vector<std::vector<std::uint32_t>>& neighbours) {
  std::vector<int> patch_of(labels.size(), -1);
  std::vector<Patch> patches;
  for (std::uint32_t seed = 0; seed < labels.size(); ++seed) {
    if (patch_of[seed] >= 0) continue;
    Patch patch;
    patch.view = labels[seed];
    const int id = static_cast<int>(patches.size());
    std::vector<std::uint32_t> stack = {seed};
    patch_of[seed] = id;
    while (!stack.empty()) {
      const std::uint32_t f = stack.back();
      stack.pop_back();
      patch.faces.push_back(f);
      for (const std::uint32_t g : neighbours[f])
        if (patch_of[g] < 0 && labels[g] == patch.view) {
          patch_of[g] = id;
          stack.push_back(g);
        }
    }
    std::sort(patch.faces.begin(), patch.faces.end());
    patches.push_back(std::move(patch));
  }
  return patches;
}

Eigen::Vector2d project(const TextureView& view, const Eigen::Vector3f& p) {
  const Eigen::Vector3d h = view.K * (view.R * p.cast<double>() + view.t);
  return h.head<2>() / h.z();
}

// A patch's vertices, their projections and its padded source rectangle.
void place_in_photo(Patch& patch, const TexturedMesh& mesh,
                    const std::vector<TextureView>& views) {
  std::unordered_map<std::uint32_t, bool> seen;
  for (const std::uint32_t f : patch.faces)
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t v = mesh.indices[3 * f + k];
      if (seen.emplace(v, true).second) patch.vertices.push_back(v);
    }
  if (patch.view < 0) {
    patch.source = cv::Rect(0, 0, 1, 1);
    return;
  }
  const TextureView& view = views[patch.view];
  double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
  for (const std::uint32_t v : patch.vertices) {
    patch.pixels.push_back(project(view, mesh.positions[v]));
    x0 = std::min(x0, patch.pixels.back().x());
    y0 = std::min(y0, patch.pixels.back().y());
    x1 = std::max(x1, patch.pixels.back().x());
    y1 = std::max(y1, patch.pixels.back().y());
  }
  const cv::Rect rect(
      static_cast<int>(std::floor(x0)) - kPadding,
      static_cast<int>(std::floor(y0)) - kPadding,
      static_cast<int>(std::ceil(x1) - std::floor(x0)) + 1 + 2 * kPadding,
      static_cast<int>(std::ceil(y1) - std::floor(y0)) + 1 + 2 * kPadding);
  patch.source = rect & cv::Rect(0, 0, view.bgr.cols, view.bgr.rows);
}

// Shelf packing at `scale`, the shelves as wide as a square of the
// patches' area would be: the atlas's size, or an empty size when it
// would pass `limit` on either side.
cv::Size pack(std::vector<Patch>& patches, double scale, int limit) {
  const auto size_of = [&](const Patch& p) {
    const double s = p.view < 0 ? 1.0 : scale;
    return cv::Size(
        std::max(1, static_cast<int>(std::ceil(p.source.width * s))) +
            2 * kPadding,
        std::max(1, static_cast<int>(std::ceil(p.source.height * s))) +
            2 * kPadding);
  };
  double area = 0;
  int widest = 0;
  for (const Patch& p : patches) {
    area += static_cast<double>(size_of(p).area());
    widest = std::max(widest, size_of(p).width);
  }
  const int width =
      std::max(widest, static_cast<int>(std::ceil(std::sqrt(area) * 1.05)));
  if (width > limit) return {};
  std::vector<std::size_t> order(patches.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(
      order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
        return size_of(patches[a]).height > size_of(patches[b]).height;
      });
  int x = 0, y = 0, shelf = 0;
  for (const std::size_t i : order) {
    const cv::Size s = size_of(patches[i]);
    if (x + s.width > width) {
      y += shelf;
      x = shelf = 0;
    }
    patches[i].target =
        cv::Rect(x + kPadding, y + kPadding, s.width - 2 * kPadding,
                 s.height - 2 * kPadding);
    x += s.width;
    shelf = std::max(shelf, s.height);
  }
  if (y + shelf > limit) return {};
  return {width, y + shelf};
}

// The photo's colour at a pixel, bilinear (BGR).
cv::Vec3d sample(const cv::Mat& bgr, const Eigen::Vector2d& p) {
  return sample_bilinear(bgr, p.x(), p.y());
}

// One gain per patch and channel: the median, over its vertices that
// other patches share, of the mean colour all those patches' photos give
// there over this patch's own; clamped, so a bad seam cannot recolour a
// patch.
void level_patches(std::vector<Patch>& patches,
                   const std::vector<TextureView>& views) {
  std::unordered_map<std::uint32_t,
                     std::vector<std::pair<std::size_t, cv::Vec3d>>>
      at;
  for (std::size_t i = 0; i < patches.size(); ++i) {
    if (patches[i].view < 0) continue;
    const cv::Mat& photo = views[patches[i].view].bgr;
    for (std::size_t k = 0; k < patches[i].vertices.size(); ++k)
      at[patches[i].vertices[k]].push_back(
          {i, sample(photo, patches[i].pixels[k])});
  }
  std::vector<std::array<std::vector<double>, 3>> ratios(patches.size());
  for (const auto& [vertex, samples] : at) {
    if (samples.size() < 2) continue;
    cv::Vec3d mean;
    for (const auto& s : samples)
      mean += s.second / static_cast<double>(samples.size());
    for (const auto& [patch, own] : samples)
      for (int c = 0; c < 3; ++c)
        if (own[c] > 8) ratios[patch][c].push_back(mean[c] / own[c]);
  }
  for (std::size_t i = 0; i < patches.size(); ++i)
    for (int c = 0; c < 3; ++c) {
      auto& r = ratios[i][c];
      if (r.size() < 3) continue;
      std::nth_element(r.begin(), r.begin() + r.size() / 2, r.end());
      patches[i].gain[c] = std::clamp(r[r.size() / 2], 0.7, 1.4);
    }
}

// Copies each patch's photo rectangle, scaled and levelled, into the atlas.
cv::Mat paint_atlas(const std::vector<Patch>& patches, const TexturedMesh& mesh,
                    const std::vector<TextureView>& views, cv::Size size) {
  cv::Mat atlas(size, CV_8UC3, cv::Scalar(0, 0, 0));
  for (const Patch& p : patches) {
    const cv::Rect padded(p.target.x - kPadding, p.target.y - kPadding,
                          p.target.width + 2 * kPadding,
                          p.target.height + 2 * kPadding);
    cv::Mat region = atlas(padded & cv::Rect(0, 0, size.width, size.height));
    if (p.view < 0) {
      cv::Vec3d mean(160, 160, 160);  // without colours: light grey
      if (!mesh.colors.empty()) mean = cv::Vec3d();
      for (const std::uint32_t v :
           mesh.colors.empty() ? std::vector<std::uint32_t>{} : p.vertices)
        for (int c = 0; c < 3; ++c)
          mean[2 - c] +=
              mesh.colors[v][c] / static_cast<double>(p.vertices.size());
      region.setTo(cv::Scalar(mean[0], mean[1], mean[2]));
      continue;
    }
    cv::Mat scaled;
    cv::resize(views[p.view].bgr(p.source), scaled, p.target.size(), 0, 0,
               cv::INTER_AREA);
    scaled.convertTo(scaled, CV_32FC3);
    cv::multiply(scaled, cv::Scalar(p.gain[0], p.gain[1], p.gain[2]), scaled);
    scaled.convertTo(scaled, CV_8UC3);
    // The padding repeats the border texels, so that sampling at a patch's
    // edge does not blend in its neighbour in the atlas.
    cv::Mat bordered;
    cv::copyMakeBorder(scaled, bordered, kPadding, kPadding, kPadding, kPadding,
                       cv::BORDER_REPLICATE);
    bordered(cv::Rect(0, 0, region.cols, region.rows)).copyTo(region);
  }
  return atlas;
}

// The mesh with each patch's own copy of its vertices and their
// coordinates in the atlas.
TexturedMesh with_uvs(const std::vector<Patch>& patches,
                      const TexturedMesh& mesh, cv::Size size) {
  const Eigen::Vector2d side(size.width, size.height);
  TexturedMesh out;
  for (const Patch& p : patches) {
    std::unordered_map<std::uint32_t, std::uint32_t> local;
    for (std::size_t k = 0; k < p.vertices.size(); ++k) {
      const std::uint32_t v = p.vertices[k];
      local[v] = static_cast<std::uint32_t>(out.positions.size());
      out.positions.push_back(mesh.positions[v]);
      if (!mesh.normals.empty()) out.normals.push_back(mesh.normals[v]);
      if (!mesh.colors.empty()) out.colors.push_back(mesh.colors[v]);
      Eigen::Vector2d texel(p.target.x + 0.5 * p.target.width,
                            p.target.y + 0.5 * p.target.height);
      if (p.view >= 0)
        texel =
            Eigen::Vector2d(p.target.x, p.target.y) +
            (p.pixels[k] - Eigen::Vector2d(p.source.x, p.source.y) +
             Eigen::Vector2d(0.5, 0.5))
                .cwiseProduct(Eigen::Vector2d(
                    static_cast<double>(p.target.width) / p.source.width,
                    static_cast<double>(p.target.height) / p.source.height));
      out.uvs.push_back(texel.cwiseQuotient(side).cast<float>());
    }
    for (const std::uint32_t f : p.faces)
      for (int k = 0; k < 3; ++k)
        out.indices.push_back(local[mesh.indices[3 * f + k]]);
  }
  return out;
}

}  // namespace

TexturedMesh build_atlas(
    const TexturedMesh& mesh, const std::vector<int>& labels,
    const std::vector<std::vector<std::uint32_t>>& neighbours,
    const std::vector<TextureView>& views, const TextureOptions& options) {
  std::vector<Patch> patches = make_patches(labels, neighbours);
  double area = 0;
  for (Patch& p : patches) {
    place_in_photo(p, mesh, views);
    area += static_cast<double>(p.source.area());
  }
  if (patches.empty()) return mesh;
  const int limit = std::max(64, options.max_atlas_side);
  double scale = std::min(1.0, 0.9 * limit / std::sqrt(std::max(area, 1.0)));
  cv::Size size;
  // Patches keep their padding at any scale: past a floor of scale, too
  // many of them for the limit leave the surface with its vertex colours.
  while ((size = pack(patches, scale, limit)).empty())
    if ((scale *= 0.9) < 1e-3) return mesh;
  level_patches(patches, views);
  TexturedMesh out = with_uvs(patches, mesh, size);
  out.atlas = paint_atlas(patches, mesh, views, size);
  return out;
}

}  // namespace arscout::engine::mesh
