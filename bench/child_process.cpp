#include "child_process.h"

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <stdexcept>
#include <system_error>

#include "arscout/util/process.h"
#include "bench_support.h"

namespace arscout::bench {

namespace fs = std::filesystem;

ChildResult run_child(const std::string& exe, std::vector<std::string> args,
                      const std::string& log) {
  args.insert(args.begin(), exe);
  const auto start = Clock::now();
  const pid_t pid = util::spawn_logged(std::move(args), log, /*append=*/false);
  ChildResult result;
  rusage usage{};
  while (wait4(pid, &result.status, 0, &usage) < 0) {
    if (errno != EINTR)
      throw std::system_error(errno, std::generic_category(), "wait4");
  }
  result.wall_s = seconds_since(start);
  result.max_rss_kib = usage.ru_maxrss;  // KiB on Linux
  return result;
}

bool arscout_runnable(const std::string& arscout) {
  if (access(arscout.c_str(), X_OK) == 0) return true;
  std::cerr << arscout << ": not executable (build the arscout target "
            << "or pass --arscout)" << std::endl;
  return false;
}

bool exited_ok(const ChildResult& r) {
  return WIFEXITED(r.status) && WEXITSTATUS(r.status) == 0;
}

std::string last_lines(const std::string& path, int count) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  std::string text;
  const auto from = lines.size() > static_cast<std::size_t>(count)
                        ? lines.size() - static_cast<std::size_t>(count)
                        : 0;
  for (auto i = from; i < lines.size(); ++i) text += lines[i] + "\n";
  return text;
}

std::string joined(const std::vector<std::string>& words) {
  std::string text;
  for (const auto& w : words) text += (text.empty() ? "" : " ") + w;
  return text;
}

std::vector<std::string> render_site_args(const BlockWalkSpec& spec,
                                          const std::string& site) {
  return {"render-site",
          "--scene",
          "block",
          "--views",
          std::to_string(spec.views),
          "--seed",
          std::to_string(spec.seed),
          "--width",
          std::to_string(spec.width),
          "--height",
          std::to_string(spec.height),
          "--out",
          site};
}

namespace {

bool rendering_reusable(const BlockWalkSpec& spec, const fs::path& site) {
  std::ifstream stamp(site / "render-args.txt");
  std::string made_by;
  if (!std::getline(stamp, made_by) ||
      made_by != joined(render_site_args(spec, site.string())))
    return false;
  int photos = 0;
  for (const auto& entry : fs::directory_iterator(site / "images"))
    photos += entry.path().extension() == ".jpg";
  return photos == spec.views && fs::exists(site / "gt_dense_cameras") &&
         fs::exists(site / "gps.csv") && fs::exists(site / "gps_truth.csv");
}

}  // namespace

void render_block_walk(const std::string& arscout, const BlockWalkSpec& spec,
                       const std::string& site, const std::string& log,
                       const std::string& label) {
  if (fs::exists(fs::path(site) / "images") && rendering_reusable(spec, site)) {
    std::cerr << label << ": reusing " << site << std::endl;
    return;
  }
  fs::remove_all(site);
  std::cerr << label << ": rendering " << spec.views << " photos" << std::endl;
  const auto args = render_site_args(spec, site);
  const ChildResult r = run_child(arscout, args, log);
  if (!exited_ok(r))
    throw std::runtime_error("render-site failed (see " + log + "):\n" +
                             last_lines(log, 5));
  std::ofstream(fs::path(site) / "render-args.txt") << joined(args) << "\n";
}

}  // namespace arscout::bench
