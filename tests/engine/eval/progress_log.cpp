#include "progress_log.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace arscout::eval {
namespace {

bool starts_with(const std::string& s, const std::string& prefix) {
  return s.compare(0, prefix.size(), prefix) == 0;
}

std::string trim(const std::string& s) {
  const auto begin = s.find_first_not_of(' ');
  if (begin == std::string::npos) return "";
  return s.substr(begin, s.find_last_not_of(' ') - begin + 1);
}

// "[n/N] rest": n, N and the offset of rest; false for another line.
bool parse_counter(const std::string& line, PhotoProgress& p,
                   std::size_t& rest) {
  int consumed = 0;
  if (std::sscanf(line.c_str(), "[%d/%d] %n", &p.number, &p.total, &consumed) !=
          2 ||
      consumed == 0 || line[static_cast<std::size_t>(consumed) - 1] != ' ')
    return false;
  rest = static_cast<std::size_t>(consumed);
  return true;
}

// The text between the '(' at `open` and its matching ')'; `end` gets the
// offset after the ')'.
std::string parenthesised(const std::string& s, std::size_t open,
                          std::size_t& end) {
  int depth = 0;
  for (std::size_t i = open; i < s.size(); ++i) {
    if (s[i] == '(') ++depth;
    if (s[i] == ')' && --depth == 0) {
      end = i + 1;
      return s.substr(open + 1, i - open - 1);
    }
  }
  throw std::runtime_error("unbalanced parentheses");
}

// "NAME  status (reason)  features 3000  pairs 9 ... geo  loop closed".
void parse_head(const std::string& head, PhotoProgress& p) {
  const auto gap = head.find("  ");
  if (gap == std::string::npos) throw std::runtime_error("no status");
  p.name = head.substr(0, gap);
  std::size_t at = head.find_first_not_of(' ', gap);
  const auto word_end = std::min(head.find(' ', at), head.size());
  p.status = head.substr(at, word_end - at);
  if (p.status != "registered" && p.status != "pending" &&
      p.status != "rejected")
    throw std::runtime_error("unknown status '" + p.status + "'");
  at = word_end;
  if (head.compare(at, 2, " (") == 0)
    p.reason = parenthesised(head, at + 1, at);
  std::istringstream words(head.substr(at));
  std::string word;
  while (words >> word) {
    if (word == "features") words >> p.features;
    if (word == "pairs") words >> p.pairs;
    if (word == "inliers") words >> p.inliers;
    if (word == "reproj") words >> p.reproj_px >> word;  // "px"
    if (word == "geo") p.geo = true;
    if (word == "component") words >> p.component;
    if (word == "merged") words >> p.merged;
    if (word == "retired") words >> p.retired;
    if (word == "loop" && words >> word && word == "closed")
      p.loop_closed = true;
    if (!words) throw std::runtime_error("bad figures");
  }
}

// "decode 0.01 ... total 1.30 s  (also registered: a.jpg b.jpg)".
void parse_tail(const std::string& tail, PhotoProgress& p) {
  const std::string also = "(also registered:";
  const auto also_at = tail.find(also);
  std::istringstream stages(tail.substr(0, also_at));
  std::string key;
  double seconds = 0;
  while (stages >> key && key != "s") {
    if (!(stages >> seconds)) throw std::runtime_error("bad stage " + key);
    p.stage_s[key] = seconds;
  }
  if (key != "s" || !p.stage_s.count("total"))
    throw std::runtime_error("no total time");
  if (also_at == std::string::npos) return;
  std::size_t end = 0;
  std::istringstream names(
      parenthesised(tail, also_at, end).substr(also.size() - 1));
  for (std::string name; names >> name;) p.also_registered.push_back(name);
}

}  // namespace

double PhotoProgress::increment_s() const {
  const auto it = stage_s.find("total");
  return it == stage_s.end() ? kNaN : it->second;
}

double ProgressLog::refine_seconds() const {
  double sum = 0;
  for (const RefineProgress& r : refines) sum += r.seconds;
  return sum;
}

double ProgressLog::dense_seconds() const {
  double sum = 0;
  for (const DenseProgress& d : dense) sum += d.seconds();
  return sum;
}

std::vector<std::string> ProgressLog::depth_map_ids() const {
  std::vector<std::string> ids;
  for (const DenseProgress& d : dense)
    ids.insert(ids.end(), d.new_depth_maps.begin(), d.new_depth_maps.end());
  return ids;
}

std::optional<PhotoProgress> parse_photo_line(const std::string& line) {
  PhotoProgress p;
  std::size_t rest = 0;
  if (!parse_counter(line, p, rest)) return std::nullopt;
  const auto bar = line.find(" | ", rest);
  parse_head(line.substr(rest, bar == std::string::npos ? bar : bar - rest), p);
  if (bar != std::string::npos) parse_tail(line.substr(bar + 3), p);
  return p;
}

std::optional<RefineProgress> parse_refine_line(const std::string& line) {
  const std::string text = trim(line);
  if (!starts_with(text, "refine: ")) return std::nullopt;
  RefineProgress r;
  if (std::sscanf(text.c_str(), "refine: %d images, %d iterations, %lf s",
                  &r.images, &r.iterations, &r.seconds) != 3)
    throw std::runtime_error("bad refine line");
  r.gave_way = text.find("(given way)") != std::string::npos;
  return r;
}

std::optional<DenseProgress> parse_dense_line(const std::string& line) {
  const std::string text = trim(line);
  if (!starts_with(text, "dense: ")) return std::nullopt;
  DenseProgress d;
  std::istringstream words(text.substr(7));
  int count = 0;
  std::string word;
  if (!(words >> count >> word >> word >> word) || count < 0)
    throw std::runtime_error("bad dense count");
  for (int i = 0; i < count && words >> word; ++i)
    d.new_depth_maps.push_back(word);
  if (static_cast<int>(d.new_depth_maps.size()) != count)
    throw std::runtime_error("too few depth map ids");
  const auto points_at = text.find("  points ");
  const auto times_at = text.find("| sweep ");
  if (points_at == std::string::npos || times_at == std::string::npos ||
      std::sscanf(text.c_str() + points_at, "  points %ld", &d.points) != 1 ||
      std::sscanf(text.c_str() + times_at, "| sweep %lf filter %lf fusion %lf",
                  &d.sweep_s, &d.filter_s, &d.fusion_s) != 3)
    throw std::runtime_error("bad dense figures");
  return d;
}

ProgressLog parse_progress_log(std::istream& in, const std::string& path) {
  ProgressLog log;
  std::string line;
  for (int line_no = 1; std::getline(in, line); ++line_no) {
    try {
      if (auto photo = parse_photo_line(line)) {
        log.photos.push_back(std::move(*photo));
      } else if (auto refine = parse_refine_line(line)) {
        refine->after_photo = log.photos.empty() ? 0 : log.photos.back().number;
        log.refines.push_back(*refine);
      } else if (auto dense = parse_dense_line(line)) {
        log.dense.push_back(std::move(*dense));
      } else if (const std::string text = trim(line);
                 starts_with(text, "waiting registered: ")) {
        int count = 0;
        if (std::sscanf(text.c_str(), "waiting registered: %d", &count) != 1)
          throw std::runtime_error("bad waiting line");
        log.waiting_registered += count;
      } else if (starts_with(text, "components merged: ")) {
        int count = 0;
        if (std::sscanf(text.c_str(), "components merged: %d", &count) != 1)
          throw std::runtime_error("bad components line");
        log.components_merged += count;
      } else if (starts_with(line, "registered ")) {
        std::sscanf(line.c_str(), "registered %d images", &log.registered);
      }
    } catch (const std::exception& e) {
      throw std::runtime_error(path + ":" + std::to_string(line_no) + ": " +
                               e.what() + ": " + line);
    }
  }
  return log;
}

ProgressLog read_progress_log(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open");
  return parse_progress_log(in, path);
}

std::vector<double> increments(const ProgressLog& log, int first, int last) {
  std::vector<double> out;
  for (const PhotoProgress& p : log.photos) {
    if (p.number < first || p.number > last) continue;
    const double s = p.increment_s();
    if (!std::isnan(s)) out.push_back(s);
  }
  return out;
}

double percentile(std::vector<double> values, double q) {
  if (values.empty()) return PhotoProgress::kNaN;
  std::sort(values.begin(), values.end());
  const double rank =
      std::clamp(q, 0.0, 1.0) * static_cast<double>(values.size() - 1);
  const auto below = static_cast<std::size_t>(std::floor(rank));
  const std::size_t above = std::min(below + 1, values.size() - 1);
  const double frac = rank - static_cast<double>(below);
  return values[below] + frac * (values[above] - values[below]);
}

}  // namespace arscout::eval
