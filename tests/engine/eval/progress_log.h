// The progress log of `arscout reconstruct`, read back: one line per photo
//
//   [12/400] 0011.jpg  registered (reason)  features 3000  pairs 9
//     inliers 812  reproj 0.310 px  geo  loop closed  | decode 0.01 ...
//     ba 0.20 total 1.30 s  (also registered: a.jpg b.jpg)
//
// (one line; `(reason)`, `geo`, `loop closed` and the `also registered`
// list are optional, and a photo the engine refused as input has no stage
// times at all), and between photos the background global adjustment:
//
//         refine: 120 images, 3 iterations, 1.95 s (given way)
//
// or the captures an increment left waiting at its limit, registered there:
//
//         waiting registered: 2 (a.jpg b.jpg), 0.41 s
//
// and with --dense, after a photo, what its dense update did:
//
//       dense: 2 new depth maps a.jpg b.jpg  (waiting: 1)  points 81234
//         (re-fused)  | sweep 1.52 filter 0.10 fusion 0.05 s
//
// (one line; the parentheses are optional and may name other counts).
// A photo's "sparse increment" is the `total` of its line; the refinement
// is not part of it. The scale bench and the block walk test judge how the
// increments grow along a walk with these.
#pragma once

#include <istream>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace arscout::eval {

struct PhotoProgress {
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  int number = 0;  // 1-based position in the input order ([number/total])
  int total = 0;
  std::string name;    // e.g. "0011.jpg"
  std::string status;  // registered | pending | rejected
  std::string reason;  // the text in parentheses after the status, or ""
  int features = 0;
  int pairs = 0;
  int inliers = 0;
  double reproj_px = kNaN;
  bool geo = false;
  bool loop_closed = false;
  int component = -1;  // "component N": the one it registered in
  int merged = 0;      // "merged N": components this increment merged
  int retired = 0;     // "retired N": stalled components it retired
  // Stage name -> seconds ("decode", "undistort", ..., "ba", "total"); empty
  // for a line without stage times.
  std::map<std::string, double> stage_s;
  std::vector<std::string> also_registered;

  // The sparse increment: stage_s["total"], NaN when the line has none.
  double increment_s() const;
};

struct RefineProgress {
  int images = 0;
  int iterations = 0;
  double seconds = 0;
  bool gave_way = false;  // stopped at its time budget, to go on later
  int after_photo = 0;    // number of the photo line before it, 0 if none
};

struct DenseProgress {
  std::vector<std::string> new_depth_maps;  // their captures' ids
  long points = 0;                          // the cloud after the update
  double sweep_s = 0, filter_s = 0, fusion_s = 0;

  double seconds() const { return sweep_s + filter_s + fusion_s; }
};

struct ProgressLog {
  std::vector<PhotoProgress> photos;  // in log order
  std::vector<RefineProgress> refines;
  std::vector<DenseProgress> dense;
  int registered = -1;         // from the final "registered N images" line; -1
  int waiting_registered = 0;  // summed over "waiting registered:" lines
  int components_merged = 0;   // summed over "components merged:" lines

  double refine_seconds() const;
  // Summed over the dense lines.
  double dense_seconds() const;
  // Every capture that got a depth map, in the order they were swept.
  std::vector<std::string> depth_map_ids() const;
};

// One photo line; nullopt for any other line. Throws std::runtime_error for
// a line that starts like a photo line ("[n/N] ") but does not parse.
std::optional<PhotoProgress> parse_photo_line(const std::string& line);
// One "refine:" line; nullopt for any other line.
std::optional<RefineProgress> parse_refine_line(const std::string& line);
// One "dense:" line; nullopt for any other line. Throws std::runtime_error
// for a dense line whose count, ids or times do not parse.
std::optional<DenseProgress> parse_dense_line(const std::string& line);

// Every photo and refine line of a log; other lines are skipped. Errors
// name the line: "PATH:LINE: what" (the path is "log" for a stream).
ProgressLog parse_progress_log(std::istream& in,
                               const std::string& path = "log");
ProgressLog read_progress_log(const std::string& path);

// The increments of the photos numbered first..last (1-based, inclusive)
// whose lines have stage times, in photo order.
std::vector<double> increments(const ProgressLog& log, int first, int last);

// Percentile q in [0, 1] with linear interpolation between the order
// statistics (numpy's default): p95 of 20 values lies between the two
// largest. NaN for no values.
double percentile(std::vector<double> values, double q);

}  // namespace arscout::eval
