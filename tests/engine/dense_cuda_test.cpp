// The CUDA plane sweep against the CPU path on the rendered street
// (rendered_street.h). Skips where the build has no CUDA path
// (-DARSCOUT_CUDA=ON) or the machine no CUDA device.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <iostream>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "arscout/engine/dense.h"
#include "dense/plane_sweep_cuda.h"
#include "rendered_street.h"

namespace arscout::engine {
namespace {

using namespace street_fixture;

template <class F>
double seconds(F&& f) {
  const auto start = std::chrono::steady_clock::now();
  f();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
      .count();
}

TEST(CudaPlaneSweep, MatchesTheCpuPathOnTheSyntheticStreet) {
  if (!cuda::available()) {
    GTEST_SKIP() << "no CUDA device (or built without -DARSCOUT_CUDA=ON): "
                    "the GPU path is not checked here";
  }
  // The street of dense_test.cpp: five cameras at 640x480, the middle one
  // the key, its two neighbours on either side.
  const cv::Size size(640, 480);
  const auto& street = rendered_street(size);
  ASSERT_EQ(street.size(), 5u);
  const auto view = [&](int i) {
    return dense_view(street[i], view_id(i),
                      sample_surface(street[i], 400, 11 + i));
  };
  const DenseView key = view(2);
  const DenseView left = view(1);
  const DenseView right = view(3);
  const std::vector<const DenseView*> neighbours = {&left, &right};

  PlaneSweepOptions options;
  DepthMap cpu, gpu;
  options.use_cuda = false;
  const double cpu_s =
      seconds([&] { cpu = sweep_planes(key, neighbours, options); });
  options.use_cuda = true;
  gpu = sweep_planes(key, neighbours, options);  // warm-up: context, module
  const double gpu_s =
      seconds([&] { gpu = sweep_planes(key, neighbours, options); });

  int both = 0, agree = 0, only_one = 0, any = 0;
  for (int y = 0; y < size.height; ++y) {
    for (int x = 0; x < size.width; ++x) {
      const float a = cpu.depth.at<float>(y, x);
      const float b = gpu.depth.at<float>(y, x);
      if (a <= 0 && b <= 0) continue;
      ++any;
      if (a > 0 && b > 0) {
        ++both;
        if (std::abs(a - b) <= 0.005 * a) ++agree;
      } else {
        ++only_one;
      }
    }
  }
  RecordProperty("cpu_seconds", std::to_string(cpu_s));
  RecordProperty("gpu_seconds", std::to_string(gpu_s));
  std::cout << "device " << cuda::device_name() << ": CPU sweep " << cpu_s
            << " s, CUDA sweep " << gpu_s << " s; " << any
            << " pixels with a depth, " << both << " in both (" << agree
            << " within 0.5%), " << only_one << " in one only\n";
  ASSERT_GT(both, 0);
  EXPECT_GE(agree, 0.98 * both);
  EXPECT_LE(only_one, 0.03 * any);
}

}  // namespace
}  // namespace arscout::engine
