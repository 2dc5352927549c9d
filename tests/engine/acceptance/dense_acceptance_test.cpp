// The dense stage on fountain-P11, with the cameras from the reconstruction
// core: coverage of every key view's filtered depth map, agreement between
// neighbouring key views, and the fused cloud drawn into a photo that was
// not used to build it.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <Eigen/Geometry>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "arscout/engine/dense_reconstruction.h"
#include "arscout/engine/model_io.h"
#include "arscout/engine/point_render.h"
#include "test_stores.h"
#include "tool_process.h"

namespace arscout {
namespace {

using testing::ToolProcess;

void run_cli(const std::vector<std::string>& args, const std::string& log) {
  ToolProcess cli(ARSCOUT_CLI, args, log);
  const auto status = cli.wait_for(std::chrono::minutes(10));
  ASSERT_TRUE(status.has_value()) << "arscout timed out\n"
                                  << testing::slurp(log);
  ASSERT_EQ(*status, 0) << testing::describe_status(*status) << "\n"
                        << testing::slurp(log);
}

std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream bytes;
  bytes << in.rdbuf();
  if (!in) throw std::runtime_error(path + ": cannot read");
  return bytes.str();
}

// The model without one image: its observations leave the tracks.
engine::Model without_image(const engine::Model& model, const std::string& id) {
  engine::Model out = model;
  out.images.clear();
  std::vector<int> new_index(model.images.size(), -1);
  for (size_t i = 0; i < model.images.size(); ++i) {
    if (model.images[i].id == id) continue;
    new_index[i] = static_cast<int>(out.images.size());
    out.images.push_back(model.images[i]);
  }
  for (engine::ModelPoint& point : out.points) {
    std::vector<std::pair<int, int>> track;
    for (const auto& [image, keypoint] : point.track)
      if (new_index[image] >= 0) track.push_back({new_index[image], keypoint});
    point.track = std::move(track);
  }
  return out;
}

// Median ZNCC of 7x7 grey patches of the photo and the rendering, over the
// pixels whose whole window the rendering covers.
double median_patch_zncc(const cv::Mat& photo, const engine::PointRendering& r,
                         int* patches) {
  cv::Mat a, b;
  cv::cvtColor(photo, a, cv::COLOR_BGR2GRAY);
  cv::cvtColor(r.bgr, b, cv::COLOR_BGR2GRAY);
  a.convertTo(a, CV_32F);
  b.convertTo(b, CV_32F);
  const cv::Mat covered = r.depth > 0;
  std::vector<double> scores;
  constexpr int kHalf = 3;
  for (int y = kHalf; y < a.rows - kHalf; y += 2) {
    for (int x = kHalf; x < a.cols - kHalf; x += 2) {
      const cv::Rect window(x - kHalf, y - kHalf, 2 * kHalf + 1, 2 * kHalf + 1);
      if (cv::countNonZero(covered(window)) < window.area()) continue;
      cv::Scalar ma, sa, mb, sb;
      cv::meanStdDev(a(window), ma, sa);
      cv::meanStdDev(b(window), mb, sb);
      if (sa[0] < 2 || sb[0] < 2) continue;  // flat: ZNCC is noise
      const double cross =
          cv::mean((a(window) - ma[0]).mul(b(window) - mb[0]))[0];
      scores.push_back(cross / (sa[0] * sb[0]));
    }
  }
  *patches = static_cast<int>(scores.size());
  if (scores.empty()) return 0;
  std::nth_element(scores.begin(), scores.begin() + scores.size() / 2,
                   scores.end());
  return scores[scores.size() / 2];
}

TEST(DenseAcceptance,
     FountainP11DepthMapsAgreeAndTheCloudMatchesAHeldOutPhoto) {
  std::string scene;
  ARSCOUT_SHARED_DATA_OR_SKIP(scene, "strecha/fountain-P11");
  const std::string images = scene + "/images";
  const std::string out = testing::make_temp_dir("dense_fountain") + "/out";
  run_cli({"reconstruct", "--images", images, "--gps-csv", scene + "/gps.csv",
           "--camera", images + "/K.txt", "--out", out},
          out + ".log");
  const engine::Model model = engine::read_colmap_text(out + "/sparse");
  ASSERT_EQ(model.images.size(), 11u);

  const std::string held_out = "0005.jpg";
  const engine::ImageSource source = [&](const std::string& id) {
    return read_bytes(images + "/" + id);
  };
  engine::DenseReconstruction dense;
  const engine::DenseUpdate update =
      dense.update(without_image(model, held_out), source);
  EXPECT_EQ(update.new_depth_maps.size(), 10u);

  const auto maps = dense.filtered_depth_maps();
  ASSERT_EQ(maps.size(), 10u);
  for (const auto& map : maps) {
    std::cout << map.id << " coverage " << map.coverage() << " (as swept "
              << dense.raw_depth_map(map.id)->coverage() << ")\n";
    EXPECT_GE(map.coverage(), 0.60) << map.id;
  }
  // Neighbouring key views: consecutive along the arc.
  for (size_t i = 0; i + 1 < maps.size(); ++i) {
    const auto agreement = engine::compare_depth_maps(maps[i], maps[i + 1]);
    std::cout << maps[i].id << " vs " << maps[i + 1].id << ": median "
              << agreement.median_relative_difference << " over "
              << agreement.compared << " pixels\n";
    EXPECT_GT(agreement.compared, 10000);
    EXPECT_LE(agreement.median_relative_difference, 0.005);
  }

  Eigen::Matrix3d K;
  const cv::Mat photo = engine::load_undistorted(
      model, held_out, source, engine::DenseOptions{}.long_side, &K);
  const auto& image = *std::find_if(
      model.images.begin(), model.images.end(),
      [&](const engine::ModelImage& m) { return m.id == held_out; });
  const Eigen::Matrix3d R = Eigen::Quaterniond(image.qvec[0], image.qvec[1],
                                               image.qvec[2], image.qvec[3])
                                .toRotationMatrix();
  const Eigen::Vector3d t(image.tvec[0], image.tvec[1], image.tvec[2]);
  // At half the dense resolution a pixel gathers about one fused point
  // (voxels are 1.5 pixel footprints at the dense resolution), so single-
  // pixel splats cover the surface without enlarging any point.
  Eigen::Matrix3d K_half = K;
  K_half.row(0) *= 0.5;
  K_half.row(1) *= 0.5;
  K_half(0, 2) = 0.5 * (K(0, 2) + 0.5) - 0.5;
  K_half(1, 2) = 0.5 * (K(1, 2) + 0.5) - 0.5;
  cv::Mat photo_half;
  cv::resize(photo, photo_half, cv::Size(photo.cols / 2, photo.rows / 2), 0, 0,
             cv::INTER_AREA);
  const engine::PointRendering rendering =
      engine::render_points(dense.points(), K_half, R, t, photo_half.size(), 0);
  if (const char* dump = std::getenv("ARSCOUT_DENSE_DUMP")) {
    cv::imwrite(std::string(dump) + "_render.png", rendering.bgr);
    cv::imwrite(std::string(dump) + "_photo.png", photo_half);
  }
  int patches = 0;
  const double zncc = median_patch_zncc(photo_half, rendering, &patches);
  std::cout << "held-out " << held_out << ": median 7x7 ZNCC " << zncc
            << " over " << patches << " patches, cloud "
            << dense.points().size() << " points\n";
  EXPECT_GT(patches, 5000);
  EXPECT_GE(zncc, 0.7);
}

}  // namespace
}  // namespace arscout
