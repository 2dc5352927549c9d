#include "serve_process.h"

#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <regex>
#include <stdexcept>
#include <thread>

namespace arscout::testing {

using namespace std::chrono_literals;

ServeProcess::ServeProcess(const std::string& cli, const std::string& db_url,
                           const std::string& log,
                           const std::vector<std::string>& extra)
    : log_(log) {
  // The global --log-level goes before the command; an --web-root in
  // `extra` replaces the default of none.
  std::vector<std::string> global, rest;
  bool web_root = false;
  for (std::size_t i = 0; i < extra.size(); ++i) {
    if (extra[i] == "--log-level" && i + 1 < extra.size()) {
      global = {extra[i], extra[i + 1]};
      ++i;
      continue;
    }
    web_root = web_root || extra[i] == "--web-root";
    rest.push_back(extra[i]);
  }
  std::vector<std::string> args = global;
  for (const char* word : {"serve", "--db"}) args.push_back(word);
  args.push_back(db_url);
  args.push_back("--listen");
  args.push_back("127.0.0.1:0");
  if (!web_root) args.insert(args.end(), {"--web-root", ""});
  args.insert(args.end(), rest.begin(), rest.end());
  process_ = std::make_unique<ToolProcess>(cli, args, log);
  static const std::regex serving(R"(arscout serving .* at (http\S+))");
  for (int i = 0; i < 300; ++i) {
    std::smatch m;
    std::string text = slurp(log);
    if (std::regex_search(text, m, serving)) {
      url_ = m[1];
      return;
    }
    if (!process_->running()) break;
    std::this_thread::sleep_for(100ms);
  }
  throw std::runtime_error("arscout serve did not start:\n" + slurp(log));
}

std::int64_t ServeProcess::status_field_kib(const std::string& field) const {
  std::ifstream in("/proc/" + std::to_string(process_->pid()) + "/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind(field + ":", 0) == 0)
      return std::stoll(line.substr(field.size() + 1));
  return -1;
}

std::int64_t ServeProcess::peak_rss_kib() const {
  return status_field_kib("VmHWM");
}

std::int64_t ServeProcess::rss_kib() const { return status_field_kib("VmRSS"); }

std::string noise_jpeg(int seed, int width, int height) {
  cv::Mat image(height, width, CV_8UC3);
  cv::RNG rng(static_cast<std::uint64_t>(seed) * 7919 + 1);
  rng.fill(image, cv::RNG::UNIFORM, 0, 256);
  std::vector<uchar> out;
  cv::imencode(".jpg", image, out, {cv::IMWRITE_JPEG_QUALITY, 60});
  return std::string(out.begin(), out.end());
}

}  // namespace arscout::testing
