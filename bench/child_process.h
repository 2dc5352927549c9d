// The child processes the benches run (arscout render-site and
// reconstruct): spawned with their output in a log file and waited for,
// with the child's wall time and peak memory; and a rendered block walk,
// made once and reused while its stamp matches.
#pragma once

#include <string>
#include <vector>

namespace arscout::bench {

struct ChildResult {
  int status = -1;       // wait status
  double wall_s = 0;     // from spawn to exit
  long max_rss_kib = 0;  // of this child alone
};

// Runs `exe args...` with stdout and stderr to `log` (truncated) and waits.
// Throws std::system_error when it cannot be spawned or waited for.
ChildResult run_child(const std::string& exe, std::vector<std::string> args,
                      const std::string& log);

// True when `arscout` can be run; else says on stderr that it is not
// executable (build the arscout target or pass --arscout).
bool arscout_runnable(const std::string& arscout);

// True when the child exited normally with status 0.
bool exited_ok(const ChildResult& r);

// The last `count` lines of the file at `path` ("" when it cannot be read),
// for an error message that shows why a child failed.
std::string last_lines(const std::string& path, int count);

// The words joined by single spaces.
std::string joined(const std::vector<std::string>& words);

// One synthetic loop walk round a city block (`render-site --scene block`).
struct BlockWalkSpec {
  int views = 400;
  int seed = 1;
  int width = 1024;
  int height = 768;
};

// render-site's arguments for `spec`, writing into `site`.
std::vector<std::string> render_site_args(const BlockWalkSpec& spec,
                                          const std::string& site);

// Renders `spec` into `site` with `arscout render-site` (its output in
// `log`), unless `site` already holds that rendering: its render-args.txt
// stamp names the same arguments and it holds the photos, gt_dense_cameras/,
// gps.csv and gps_truth.csv. Says which on stderr, prefixed by `label`.
// Throws std::runtime_error with the log's last lines when render-site fails.
void render_block_walk(const std::string& arscout, const BlockWalkSpec& spec,
                       const std::string& site, const std::string& log,
                       const std::string& label);

}  // namespace arscout::bench
