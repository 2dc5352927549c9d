// Patch alignment on images with a known sub-pixel shift: a smooth random
// texture rendered twice, the second moved, brighter and with more
// contrast, and keypoints placed off the true spot as a detector would.
#include "features/keypoint_refinement.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

namespace arscout::engine {
namespace {

cv::Mat smooth_texture(int size, unsigned seed) {
  cv::Mat noise(size, size, CV_32F);
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::UNIFORM, 0, 255);
  cv::Mat smooth;
  cv::GaussianBlur(noise, smooth, cv::Size(0, 0), 2.0);
  cv::normalize(smooth, smooth, 20, 235, cv::NORM_MINMAX);
  return smooth;
}

// `texture` moved by `shift` (content at x shows up at x + shift), with a
// gain and a bias, as 8-bit gray.
cv::Mat moved(const cv::Mat& texture, const Eigen::Vector2d& shift, double gain,
              double bias) {
  const cv::Mat warp =
      (cv::Mat_<double>(2, 3) << 1, 0, shift.x(), 0, 1, shift.y());
  cv::Mat out;
  cv::warpAffine(texture, out, warp, texture.size(), cv::INTER_CUBIC,
                 cv::BORDER_REFLECT);
  out.convertTo(out, CV_8U, gain, bias);
  return out;
}

TEST(KeypointRefinementTest, MovesAKeypointOntoTheReferenceSpot) {
  const cv::Mat texture = smooth_texture(200, 7);
  const Eigen::Vector2d shift(0.37, -0.61);
  const cv::Mat a = moved(texture, Eigen::Vector2d::Zero(), 1.0, 0);
  const cv::Mat b = moved(texture, shift, 1.2, 15);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> where(40, 160);
  std::uniform_real_distribution<double> off(-0.8, 0.8);
  std::vector<double> before, after;
  for (int i = 0; i < 100; ++i) {
    const Eigen::Vector2d in_a(where(rng), where(rng));
    const Eigen::Vector2d truth = in_a + shift;
    const Eigen::Vector2d detected =
        truth + Eigen::Vector2d(off(rng), off(rng));
    const cv::Mat pa = extract_patches(a, {in_a});
    const cv::Mat pb = extract_patches(b, {detected});
    ASSERT_EQ(pa.cols, kPatchSide * kPatchSide);
    const auto correction = align_patch(pa.ptr<uchar>(0), pb.ptr<uchar>(0));
    if (!correction) continue;
    before.push_back((detected - truth).norm());
    after.push_back((detected + *correction - truth).norm());
  }
  ASSERT_GE(after.size(), 90u);
  std::sort(before.begin(), before.end());
  std::sort(after.begin(), after.end());
  const double median_after = after[after.size() / 2];
  std::printf("median offset %.3f -> %.3f px, largest after %.3f px\n",
              before[before.size() / 2], median_after, after.back());
  EXPECT_LT(median_after, 0.06);
  EXPECT_LT(after.back(), 0.2);
  EXPECT_LT(median_after, before[before.size() / 2] / 5);
}

// Three views of one texture: the reference, a neighbour whose keypoint
// was detected off the reference's spot, and the target. Aligned to the
// neighbour's patch at the neighbour's own shift, the target lands on the
// reference's spot, not on the neighbour's detected one.
TEST(KeypointRefinementTest, AlignsThroughANeighbourAtItsShift) {
  const cv::Mat texture = smooth_texture(200, 11);
  const Eigen::Vector2d to_neighbour(0.8, -0.3), to_target(-0.45, 0.9);
  const cv::Mat a = moved(texture, Eigen::Vector2d::Zero(), 1.0, 0);
  const cv::Mat b = moved(texture, to_neighbour, 0.9, 10);
  const cv::Mat c = moved(texture, to_target, 1.1, -5);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> where(40, 160);
  std::uniform_real_distribution<double> off(-0.7, 0.7);
  std::vector<double> through, at_neighbour_centre;
  for (int i = 0; i < 100; ++i) {
    const Eigen::Vector2d in_a(where(rng), where(rng));
    const Eigen::Vector2d in_b =
        in_a + to_neighbour + Eigen::Vector2d(off(rng), off(rng));
    const Eigen::Vector2d truth_c = in_a + to_target;
    const Eigen::Vector2d in_c = truth_c + Eigen::Vector2d(off(rng), off(rng));
    const cv::Mat pa = extract_patches(a, {in_a});
    const cv::Mat pb = extract_patches(b, {in_b});
    const cv::Mat pc = extract_patches(c, {in_c});
    const auto b_onto_a = align_patch(pa.ptr<uchar>(0), pb.ptr<uchar>(0));
    if (!b_onto_a) continue;
    const auto c_onto_a =
        align_patch(pb.ptr<uchar>(0), pc.ptr<uchar>(0), *b_onto_a);
    const auto c_onto_b = align_patch(pb.ptr<uchar>(0), pc.ptr<uchar>(0));
    if (!c_onto_a || !c_onto_b) continue;
    through.push_back((in_c + *c_onto_a - truth_c).norm());
    at_neighbour_centre.push_back((in_c + *c_onto_b - truth_c).norm());
  }
  ASSERT_GE(through.size(), 80u);
  std::sort(through.begin(), through.end());
  std::sort(at_neighbour_centre.begin(), at_neighbour_centre.end());
  const double median = through[through.size() / 2];
  const double median_centre =
      at_neighbour_centre[at_neighbour_centre.size() / 2];
  std::printf(
      "through the neighbour's shift %.3f px (largest %.3f), at its "
      "detected centre %.3f px\n",
      median, through.back(), median_centre);
  EXPECT_LT(median, 0.08);
  EXPECT_LT(through.back(), 0.3);
  EXPECT_GT(median_centre, 3 * median);
}

TEST(KeypointRefinementTest, RefusesFlatAndUnrelatedPatches) {
  const cv::Mat flat(100, 100, CV_8U, cv::Scalar(128));
  const cv::Mat texture = moved(smooth_texture(100, 1), {0, 0}, 1, 0);
  const cv::Mat other = moved(smooth_texture(100, 2), {0, 0}, 1, 0);
  const Eigen::Vector2d at(50, 50);
  const cv::Mat p_flat = extract_patches(flat, {at});
  const cv::Mat p_texture = extract_patches(texture, {at});
  EXPECT_FALSE(align_patch(p_flat.ptr<uchar>(0), p_texture.ptr<uchar>(0)));
  EXPECT_FALSE(align_patch(p_texture.ptr<uchar>(0), p_flat.ptr<uchar>(0)));
  // Unrelated texture: a 7 x 7 window searched over 3 px may find a look-alike
  // now and then, but most are refused.
  int accepted = 0;
  for (int y = 20; y < 80; y += 6) {
    for (int x = 20; x < 80; x += 6) {
      const cv::Mat pa = extract_patches(texture, {{double(x), double(y)}});
      const cv::Mat pb = extract_patches(other, {{double(x), double(y)}});
      if (align_patch(pa.ptr<uchar>(0), pb.ptr<uchar>(0))) ++accepted;
    }
  }
  std::printf("unrelated patches accepted: %d of 100\n", accepted);
  EXPECT_LE(accepted, 20);
  // The same patch needs no move.
  const auto same =
      align_patch(p_texture.ptr<uchar>(0), p_texture.ptr<uchar>(0));
  ASSERT_TRUE(same);
  EXPECT_LT(same->norm(), 1e-6);
}

TEST(KeypointRefinementTest, PatchesRepeatTheBorderBeyondTheImage) {
  cv::Mat gray(20, 20, CV_8U);
  for (int y = 0; y < 20; ++y)
    for (int x = 0; x < 20; ++x)
      gray.at<uchar>(y, x) = static_cast<uchar>(10 * x);
  const cv::Mat patches = extract_patches(gray, {{0.0, 5.0}, {19.0, 5.0}});
  ASSERT_EQ(patches.rows, 2);
  const int centre = kPatchSide / 2;
  // Left of column 0 the first column repeats; right of 19 the last.
  EXPECT_EQ(patches.at<uchar>(0, centre * kPatchSide + 0), 0);
  EXPECT_EQ(patches.at<uchar>(0, centre * kPatchSide + centre), 0);
  EXPECT_EQ(patches.at<uchar>(0, centre * kPatchSide + kPatchSide - 1),
            10 * (kPatchSide - 1 - centre));
  EXPECT_EQ(patches.at<uchar>(1, centre * kPatchSide + kPatchSide - 1), 190);
}

}  // namespace
}  // namespace arscout::engine
