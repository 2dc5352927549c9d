// `arscout depth`: one key view's plane-sweep depth map from a model that
// `arscout reconstruct` wrote, as a 16-bit PNG in millimetres and a
// colourised preview, for inspecting the dense stage one view at a time.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "arscout/engine/dense_reconstruction.h"
#include "arscout/engine/model_io.h"
#include "arscout/util/error.h"
#include "cli_support.h"
#include "command_registry.h"
#include "commands.h"

namespace arscout::cli {
namespace {

namespace fs = std::filesystem;

struct DepthArgs {
  std::string model;
  std::string images;
  std::string key;
  std::string output;
  engine::DenseOptions options;
};

// --model may name the reconstruct output folder or its sparse/ folder.
fs::path sparse_folder(const fs::path& model) {
  if (fs::exists(model / "images.txt")) return model;
  if (fs::exists(model / "sparse" / "images.txt")) return model / "sparse";
  throw util::Error(util::ErrorKind::kInvalidArgument,
                    model.string() +
                        ": no COLMAP text model (images.txt) here "
                        "or in sparse/");
}

// The photo folder: --images, else the one `arscout reconstruct` recorded
// in OUT/sources.txt.
fs::path images_folder(const DepthArgs& a, const fs::path& sparse) {
  if (!a.images.empty()) return a.images;
  std::ifstream in(sparse.parent_path() / "sources.txt");
  std::string key, value;
  while (in >> key && std::getline(in >> std::ws, value)) {
    if (key == "images") return value;
  }
  throw util::Error(util::ErrorKind::kInvalidArgument,
                    "no --images given and no sources.txt beside the model");
}

cv::Mat millimetres(const cv::Mat& depth) {
  cv::Mat mm(depth.size(), CV_16U, cv::Scalar(0));
  for (int y = 0; y < depth.rows; ++y)
    for (int x = 0; x < depth.cols; ++x) {
      const float z = depth.at<float>(y, x);
      if (z > 0)
        mm.at<uint16_t>(y, x) = static_cast<uint16_t>(
            std::clamp(std::lround(z * 1000.0), 1L, 65535L));
    }
  return mm;
}

// Near is warm, far is cool (the 2nd-98th percentile range), none is black.
cv::Mat preview(const cv::Mat& depth) {
  std::vector<float> values;
  for (int y = 0; y < depth.rows; ++y)
    for (int x = 0; x < depth.cols; ++x)
      if (depth.at<float>(y, x) > 0) values.push_back(depth.at<float>(y, x));
  cv::Mat colour = cv::Mat::zeros(depth.size(), CV_8UC3);
  if (values.empty()) return colour;
  std::sort(values.begin(), values.end());
  const float lo = values[values.size() / 50];
  const float hi = values[values.size() - 1 - values.size() / 50];
  cv::Mat scaled(depth.size(), CV_8U);
  for (int y = 0; y < depth.rows; ++y)
    for (int x = 0; x < depth.cols; ++x) {
      const float t = (depth.at<float>(y, x) - lo) / std::max(hi - lo, 1e-6f);
      scaled.at<uint8_t>(y, x) =
          static_cast<uint8_t>(255 - std::clamp(t, 0.0f, 1.0f) * 255);
    }
  cv::applyColorMap(scaled, colour, cv::COLORMAP_TURBO);
  colour.setTo(cv::Scalar(0, 0, 0), depth <= 0);
  return colour;
}

fs::path preview_path(const fs::path& output) {
  return output.parent_path() /
         (output.stem().string() + "_preview" + output.extension().string());
}

void write_png(const fs::path& path, const cv::Mat& image) {
  if (!cv::imwrite(path.string(), image))
    throw util::Error(util::ErrorKind::kInternal,
                      path.string() + ": cannot write");
}

int run_depth(const DepthArgs& a) {
  const fs::path sparse = sparse_folder(a.model);
  engine::Model model;
  try {
    model = engine::read_colmap_text(sparse.string());
  } catch (const std::runtime_error& e) {
    throw util::Error(util::ErrorKind::kInvalidArgument, e.what());
  }
  const fs::path images = images_folder(a, sparse);
  const engine::ImageSource source = [&](const std::string& id) {
    return read_input_file((images / id).string());
  };
  engine::DepthMap map;
  try {
    map = engine::compute_key_depth_map(model, a.key, source, a.options);
  } catch (const std::invalid_argument& e) {
    throw util::Error(util::ErrorKind::kInvalidArgument, e.what());
  }
  const fs::path output = a.output;
  if (output.has_parent_path()) fs::create_directories(output.parent_path());
  write_png(output, millimetres(map.depth));
  write_png(preview_path(output), preview(map.depth));
  std::cout << a.key << ": depth for " << std::lround(100 * map.coverage())
            << " % of " << map.depth.cols << "x" << map.depth.rows
            << " pixels; wrote " << output.string() << " (16-bit, mm) and "
            << preview_path(output).string() << std::endl;
  return kExitOk;
}

void add_depth_command(CLI::App& app) {
  static DepthArgs args;
  CLI::App* cmd = app.add_subcommand(
      "depth",
      "one key view's plane-sweep depth map (with its two best neighbours) "
      "from a model written by `arscout reconstruct`: a 16-bit PNG in "
      "millimetres (0 = no depth) and NAME_preview.png");
  cmd->add_option("--model", args.model,
                  "the reconstruct output folder (or its sparse/ folder)")
      ->required()
      ->check(CLI::ExistingDirectory);
  cmd->add_option("--key", args.key, "the key view's image name, e.g. 0005.jpg")
      ->required();
  cmd->add_option("-o,--output", args.output, "depth PNG to write")->required();
  cmd->add_option("--images", args.images,
                  "photo folder (default: the one recorded by reconstruct)")
      ->check(CLI::ExistingDirectory);
  cmd->add_option("--long-side", args.options.long_side,
                  "dense working resolution, long side in px")
      ->capture_default_str()
      ->check(CLI::Range(100, 10000));
  cmd->add_flag("--cuda", args.options.sweep.use_cuda,
                "sweep on the GPU when built with CUDA and a device exists");
  cmd->callback([] { run_command([] { return run_depth(args); }); });
}

const CommandRegistration depth_command_registration(52, add_depth_command);

}  // namespace
}  // namespace arscout::cli
