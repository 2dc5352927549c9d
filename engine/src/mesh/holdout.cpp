// holdout_scores: each view predicted by the surface textured from the
// others.
#include <opencv2/imgproc.hpp>

#include "arscout/engine/mesh.h"

namespace arscout::engine {
namespace {

// ZNCC of the grey levels of a and b over the pixels of `mask`; 0 when
// either is flat there or the mask is empty.
double masked_zncc(const cv::Mat& a, const cv::Mat& b, const cv::Mat& mask) {
  if (cv::countNonZero(mask) == 0) return 0;
  cv::Mat ga, gb;
  cv::cvtColor(a, ga, cv::COLOR_BGR2GRAY);
  cv::cvtColor(b, gb, cv::COLOR_BGR2GRAY);
  cv::Scalar ma, sa, mb, sb;
  cv::meanStdDev(ga, ma, sa, mask);
  cv::meanStdDev(gb, mb, sb, mask);
  if (sa[0] <= 0 || sb[0] <= 0) return 0;
  cv::Mat fa, fb, weight;
  ga.convertTo(fa, CV_64F, 1, -ma[0]);
  gb.convertTo(fb, CV_64F, 1, -mb[0]);
  mask.convertTo(weight, CV_64F, 1.0 / 255);
  return fa.mul(fb).dot(weight) / (cv::countNonZero(mask) * sa[0] * sb[0]);
}

}  // namespace

std::vector<HoldoutScore> holdout_scores(const TexturedMesh& surface,
                                         const std::vector<TextureView>& views,
                                         const TextureOptions& options,
                                         const std::vector<std::size_t>& held) {
  std::vector<std::size_t> all(views.size());
  for (std::size_t v = 0; v < views.size(); ++v) all[v] = v;
  std::vector<HoldoutScore> scores;
  for (const std::size_t view_index : held.empty() ? all : held) {
    std::vector<TextureView> others;
    for (std::size_t v = 0; v < views.size(); ++v)
      if (v != view_index) others.push_back(views[v]);
    const TextureView& view = views[view_index];
    const MeshRendering drawn =
        render_mesh(texture_mesh(surface, others, options), view.K, view.R,
                    view.t, view.bgr.size());
    const cv::Mat covered = drawn.depth > 0;
    scores.push_back(
        {view.id, masked_zncc(drawn.bgr, view.bgr, covered),
         cv::countNonZero(covered) / static_cast<double>(covered.total())});
  }
  return scores;
}

}  // namespace arscout::engine
