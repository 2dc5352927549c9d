// feature_bench: which keypoint detector/descriptor the reconstruction should
// keep for wide-baseline matching, measured on the real images in
// ../shared/data. Figures and the reading are in bench/FEATURES.md.
//
// For each dataset every alternative detects and describes every image at
// the working resolution, matches the pairs (i, i+1) and (i, i+2) in file
// name order ((i, i+2) is the wide baseline) and verifies them geometrically:
//
//   harris-sift  Harris corners, sub-pixel refined, upright RootSIFT
//                descriptors at one fixed keypoint size
//   sift         SIFT detector and descriptor, RootSIFT
//   orb          ORB, Hamming distance
//   akaze        AKAZE (binary MLDB descriptor), Hamming distance
//
// Matching: brute-force 2-NN in both directions, Lowe ratio 0.8 in both,
// mutual best only. Verification: RANSAC essential matrix (1 px, p 0.999)
// with the dataset's K scaled to the working resolution, or a fundamental
// matrix (1 px) where no calibration is known (lund).
//
//   feature_bench [--data DIR] [--datasets fountain,entry,temple,lund]
//                 [--methods harris-sift,sift,orb,akaze] [--long-side 1600]
//                 [--threads 2] [--repeat 1] [--cpu-time] [--harris-size 12]
//                 [--markdown]
//
// On a shared machine pass --repeat 3 or more (each detection, matching and
// RANSAC is timed that many times and the fastest kept) and compare with a
// --cpu-time run, which other processes' load barely moves.
#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <exception>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <numeric>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#ifndef ARSCOUT_SOURCE_DIR
#define ARSCOUT_SOURCE_DIR "."
#endif

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

constexpr int kMaxFeatures = 4000;
constexpr float kRatio = 0.8f;
constexpr double kRansacPx = 1.0;
constexpr double kRansacProb = 0.999;
// Above OpenCV's default of 1000: with a 5-point sample and a 25 % inlier
// ratio, p 0.999 needs about 7000 draws, and a weak method should not lose
// its inliers to an early stop. Adaptive termination keeps easy pairs fast.
constexpr int kRansacIters = 10000;
constexpr int kGoodPairInliers = 50;
// AKAZE's default threshold finds few points on low-texture images; below
// this count it is run again with a lower threshold.
constexpr size_t kAkazeMinKeypoints = 1000;

struct Timing {
  int repeat = 1;    // timed runs per operation, fastest kept
  bool cpu = false;  // process CPU time instead of wall clock
};

struct Config {
  std::string data_dir = std::string(ARSCOUT_SOURCE_DIR) + "/../shared/data";
  std::vector<std::string> datasets = {"fountain", "entry", "temple", "lund"};
  std::vector<std::string> methods = {"harris-sift", "sift", "orb", "akaze"};
  int long_side = 1600;
  int threads = 2;
  Timing timing;
  float harris_size = 12.0f;
  bool markdown = false;
};

double ms_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start)
      .count();
}

double mean(const std::vector<double>& v) {
  if (v.empty()) return 0.0;
  return std::accumulate(v.begin(), v.end(), 0.0) /
         static_cast<double>(v.size());
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<long>(mid), v.end());
  if (v.size() % 2 == 1) return v[mid];
  const double upper = v[mid];
  const double lower =
      *std::max_element(v.begin(), v.begin() + static_cast<long>(mid));
  return 0.5 * (lower + upper);
}

// --- image headers ----------------------------------------------------------
// The size comes from the header alone, so the JPEG decoder can be told to
// scale down (IMREAD_REDUCED_*) before it decodes any pixels.

int be16(const std::vector<uchar>& b, size_t i) {
  return (b[i] << 8) | b[i + 1];
}

int be32(const std::vector<uchar>& b, size_t i) {
  return (be16(b, i) << 16) | be16(b, i + 2);
}

std::optional<cv::Size> png_size(const std::vector<uchar>& b) {
  // 8-byte signature, then IHDR: length, "IHDR", width, height.
  static const uchar kIhdr[] = {'I', 'H', 'D', 'R'};
  if (b.size() < 24 || !std::equal(kIhdr, kIhdr + 4, b.begin() + 12)) {
    return std::nullopt;
  }
  return cv::Size(be32(b, 16), be32(b, 20));
}

// SOF0..SOF15 carry the frame size; C4 (DHT), C8 (JPG) and CC (DAC) are not
// frame headers although they share the range.
bool is_sof(int marker) {
  return marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 &&
         marker != 0xCC;
}

std::optional<cv::Size> jpeg_size(const std::vector<uchar>& b) {
  size_t i = 2;  // after SOI
  while (i + 9 < b.size()) {
    if (b[i] != 0xFF) return std::nullopt;
    const int marker = b[i + 1];
    if (marker == 0xFF) {  // fill byte before a marker
      ++i;
    } else if (is_sof(marker)) {
      return cv::Size(be16(b, i + 7), be16(b, i + 5));
    } else if ((marker >= 0xD0 && marker <= 0xD8) || marker == 0x01) {
      i += 2;  // markers without a length field
    } else {
      i += 2 + static_cast<size_t>(be16(b, i + 2));
    }
  }
  return std::nullopt;
}

cv::Size header_size(const std::vector<uchar>& b, const fs::path& path) {
  std::optional<cv::Size> size;
  if (b.size() > 2 && b[0] == 0xFF && b[1] == 0xD8) size = jpeg_size(b);
  if (b.size() > 8 && b[0] == 0x89 && b[1] == 'P') size = png_size(b);
  if (!size) throw std::runtime_error("no JPEG/PNG size in " + path.string());
  return *size;
}

// --- images -----------------------------------------------------------------

struct Image {
  std::string name;
  cv::Mat gray;       // at the working resolution
  cv::Size original;  // as stored
  double decode_ms = 0.0;
};

std::vector<uchar> read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + path.string());
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// The largest decoder reduction that still leaves at least long_side pixels,
// so no detail is lost that the final INTER_AREA resize would have kept.
int reduce_flag(cv::Size original, int long_side) {
  const int longest = std::max(original.width, original.height);
  if (longest / 8 >= long_side) return cv::IMREAD_REDUCED_GRAYSCALE_8;
  if (longest / 4 >= long_side) return cv::IMREAD_REDUCED_GRAYSCALE_4;
  if (longest / 2 >= long_side) return cv::IMREAD_REDUCED_GRAYSCALE_2;
  return cv::IMREAD_GRAYSCALE;
}

// Decodes straight to grayscale (libjpeg then skips colour conversion): every
// alternative works on intensity only. Never upscales a smaller image.
cv::Mat decode_working(const std::vector<uchar>& bytes, cv::Size original,
                       int long_side) {
  cv::Mat gray = cv::imdecode(bytes, reduce_flag(original, long_side));
  if (gray.empty()) return gray;  // the caller names the file
  const int longest = std::max(gray.cols, gray.rows);
  if (longest <= long_side) return gray;
  const double s = static_cast<double>(long_side) / longest;
  const cv::Size size(static_cast<int>(std::lround(gray.cols * s)),
                      static_cast<int>(std::lround(gray.rows * s)));
  cv::Mat resized;
  cv::resize(gray, resized, size, 0, 0, cv::INTER_AREA);
  return resized;
}

Image load_image(const fs::path& path, int long_side) {
  Image image;
  image.name = path.filename().string();
  const std::vector<uchar> bytes = read_bytes(path);
  image.original = header_size(bytes, path);
  const auto start = Clock::now();
  image.gray = decode_working(bytes, image.original, long_side);
  image.decode_ms = ms_since(start);
  if (image.gray.empty()) {
    throw std::runtime_error("cannot decode " + path.string());
  }
  return image;
}

bool is_image_file(const fs::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  return ext == ".jpg" || ext == ".jpeg" || ext == ".png";
}

std::vector<fs::path> list_images(const fs::path& dir) {
  std::vector<fs::path> paths;
  for (const auto& entry : fs::directory_iterator(dir)) {
    if (entry.is_regular_file() && is_image_file(entry.path())) {
      paths.push_back(entry.path());
    }
  }
  std::sort(paths.begin(), paths.end());  // file-name order defines pairs
  return paths;
}

// --- datasets and calibration -----------------------------------------------

enum class Calib { kStrecha, kMiddlebury, kNone };

struct DatasetSpec {
  const char* name;
  const char* images;  // relative to --data
  Calib calib;
  const char* k_file;  // relative to the images folder
};

const DatasetSpec kDatasets[] = {
    {"fountain", "strecha/fountain-P11/images", Calib::kStrecha, "K.txt"},
    {"entry", "strecha/entry-P10/images", Calib::kStrecha, "K.txt"},
    {"temple", "middlebury/templeSparseRing", Calib::kMiddlebury,
     "templeSR_par.txt"},
    {"lund", "opensfm/lund/images", Calib::kNone, ""},
};

const DatasetSpec& find_dataset(const std::string& name) {
  for (const auto& spec : kDatasets) {
    if (name == spec.name) return spec;
  }
  throw std::runtime_error("unknown dataset '" + name +
                           "' (fountain, entry, temple, lund)");
}

cv::Matx33d read_k(std::istream& in, const std::string& what) {
  cv::Matx33d k;
  for (int i = 0; i < 9; ++i) in >> k.val[i];
  if (!in) throw std::runtime_error("cannot parse K from " + what);
  return k;
}

// Strecha K.txt: the 3x3 matrix, row by row. Middlebury *_par.txt: the image
// count, then "name k11 .. k33 r11 .. t3" per image; all share one K.
std::optional<cv::Matx33d> read_full_res_k(const DatasetSpec& spec,
                                           const fs::path& dir) {
  if (spec.calib == Calib::kNone) return std::nullopt;
  const fs::path path = dir / spec.k_file;
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read " + path.string());
  if (spec.calib == Calib::kMiddlebury) {
    int count = 0;
    std::string name;
    in >> count >> name;
  }
  return read_k(in, path.string());
}

// K belongs to the stored resolution; the points are at the working one.
cv::Matx33d scale_k(cv::Matx33d k, double sx, double sy) {
  k(0, 0) *= sx;
  k(0, 2) *= sx;
  k(1, 1) *= sy;
  k(1, 2) *= sy;
  return k;
}

struct Dataset {
  std::string name;
  std::string folder;
  std::vector<Image> images;
  std::optional<cv::Matx33d> k;  // at the working resolution
};

Dataset load_dataset(const DatasetSpec& spec, const Config& cfg) {
  const fs::path dir = fs::path(cfg.data_dir) / spec.images;
  if (!fs::is_directory(dir)) {
    throw std::runtime_error("dataset folder missing: " + dir.string());
  }
  Dataset ds{spec.name, spec.images, {}, std::nullopt};
  for (const auto& path : list_images(dir)) {
    ds.images.push_back(load_image(path, cfg.long_side));
  }
  if (ds.images.size() < 2) {
    throw std::runtime_error("too few images in " + dir.string());
  }
  if (auto k = read_full_res_k(spec, dir)) {
    const Image& first = ds.images.front();
    ds.k =
        scale_k(*k, static_cast<double>(first.gray.cols) / first.original.width,
                static_cast<double>(first.gray.rows) / first.original.height);
  }
  return ds;
}

// --- alternatives -----------------------------------------------------------

struct Features {
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  int norm = cv::NORM_L2;
};

// RootSIFT (Arandjelovic & Zisserman 2012): L1-normalise, then square root,
// so that L2 distance between descriptors is the Hellinger kernel, which
// matches better than plain L2 on SIFT histograms.
void root_sift(cv::Mat& descriptors) {
  for (int r = 0; r < descriptors.rows; ++r) {
    float* d = descriptors.ptr<float>(r);
    const float sum = std::accumulate(d, d + descriptors.cols, 0.0f);
    if (sum <= 0.0f) continue;
    for (int c = 0; c < descriptors.cols; ++c) d[c] = std::sqrt(d[c] / sum);
  }
}

// Harris corners localise well but carry no scale or orientation, so the
// descriptor is upright at one fixed size; octave 0 keeps SIFT from
// upsampling the image to build its pyramid.
Features harris_sift(const cv::Mat& gray, cv::SIFT& sift, float size) {
  std::vector<cv::Point2f> corners;
  cv::goodFeaturesToTrack(gray, corners, kMaxFeatures, 0.001, 5.0,
                          cv::noArray(), 3, /*useHarrisDetector=*/true, 0.04);
  if (!corners.empty()) {
    const cv::TermCriteria stop(cv::TermCriteria::COUNT | cv::TermCriteria::EPS,
                                30, 0.01);
    cv::cornerSubPix(gray, corners, cv::Size(4, 4), cv::Size(-1, -1), stop);
  }
  Features f;
  for (const auto& c : corners) {
    f.keypoints.emplace_back(c, size, /*angle=*/0.0f, /*response=*/0.0f,
                             /*octave=*/0);
  }
  sift.compute(gray, f.keypoints, f.descriptors);
  root_sift(f.descriptors);
  return f;
}

Features sift_features(const cv::Mat& gray, cv::SIFT& sift) {
  Features f;
  sift.detectAndCompute(gray, cv::noArray(), f.keypoints, f.descriptors);
  root_sift(f.descriptors);
  return f;
}

Features orb_features(const cv::Mat& gray, cv::ORB& orb) {
  Features f;
  f.norm = cv::NORM_HAMMING;
  orb.detectAndCompute(gray, cv::noArray(), f.keypoints, f.descriptors);
  return f;
}

// AKAZE has no feature cap; the strongest kMaxFeatures keep it comparable
// with the others (and its matching time bounded).
void keep_strongest(Features& f, size_t n) {
  if (f.keypoints.size() <= n) return;
  std::vector<int> order(f.keypoints.size());
  std::iota(order.begin(), order.end(), 0);
  std::partial_sort(order.begin(), order.begin() + static_cast<long>(n),
                    order.end(), [&](int a, int b) {
                      return f.keypoints[a].response > f.keypoints[b].response;
                    });
  Features kept;
  kept.norm = f.norm;
  for (size_t i = 0; i < n; ++i) {
    kept.keypoints.push_back(f.keypoints[order[i]]);
    kept.descriptors.push_back(f.descriptors.row(order[i]));
  }
  f = std::move(kept);
}

Features akaze_features(const cv::Mat& gray) {
  Features f;
  f.norm = cv::NORM_HAMMING;
  auto akaze = cv::AKAZE::create();
  akaze->detectAndCompute(gray, cv::noArray(), f.keypoints, f.descriptors);
  if (f.keypoints.size() < kAkazeMinKeypoints) {
    akaze->setThreshold(0.0005);
    akaze->detectAndCompute(gray, cv::noArray(), f.keypoints, f.descriptors);
  }
  keep_strongest(f, kMaxFeatures);
  return f;
}

using Extractor = std::function<Features(const cv::Mat&)>;

Extractor make_extractor(const std::string& method, const Config& cfg) {
  if (method == "harris-sift") {
    cv::Ptr<cv::SIFT> sift = cv::SIFT::create();
    const float size = cfg.harris_size;
    return
        [sift, size](const cv::Mat& g) { return harris_sift(g, *sift, size); };
  }
  if (method == "sift") {
    cv::Ptr<cv::SIFT> sift = cv::SIFT::create(kMaxFeatures);
    return [sift](const cv::Mat& g) { return sift_features(g, *sift); };
  }
  if (method == "orb") {
    cv::Ptr<cv::ORB> orb = cv::ORB::create(kMaxFeatures);
    return [orb](const cv::Mat& g) { return orb_features(g, *orb); };
  }
  if (method == "akaze") return akaze_features;
  throw std::runtime_error("unknown method '" + method +
                           "' (harris-sift, sift, orb, akaze)");
}

// --- matching and verification ----------------------------------------------

// For each query row, its nearest train row if it passes the ratio test,
// else -1.
std::vector<int> ratio_nearest(const cv::Mat& query, const cv::Mat& train,
                               int norm) {
  std::vector<std::vector<cv::DMatch>> knn;
  cv::BFMatcher(norm).knnMatch(query, train, knn, 2);
  std::vector<int> best(static_cast<size_t>(query.rows), -1);
  for (const auto& k : knn) {
    if (k.size() == 2 && k[0].distance < kRatio * k[1].distance) {
      best[static_cast<size_t>(k[0].queryIdx)] = k[0].trainIdx;
    }
  }
  return best;
}

// Ratio test both ways, then only mutual nearest neighbours: the cross check
// removes most of the many-to-one matches on repeated facade texture.
std::vector<cv::DMatch> match_mutual(const Features& a, const Features& b) {
  if (a.descriptors.rows < 2 || b.descriptors.rows < 2) return {};
  const auto ab = ratio_nearest(a.descriptors, b.descriptors, a.norm);
  const auto ba = ratio_nearest(b.descriptors, a.descriptors, a.norm);
  std::vector<cv::DMatch> matches;
  for (size_t i = 0; i < ab.size(); ++i) {
    const int j = ab[i];
    if (j >= 0 && ba[static_cast<size_t>(j)] == static_cast<int>(i)) {
      matches.emplace_back(static_cast<int>(i), j, 0.0f);
    }
  }
  return matches;
}

int count_inliers(const Features& a, const Features& b,
                  const std::vector<cv::DMatch>& matches,
                  const std::optional<cv::Matx33d>& k) {
  if (matches.size() < 8) return 0;  // below the 8-point minimum
  std::vector<cv::Point2f> pa, pb;
  for (const auto& m : matches) {
    pa.push_back(a.keypoints[static_cast<size_t>(m.queryIdx)].pt);
    pb.push_back(b.keypoints[static_cast<size_t>(m.trainIdx)].pt);
  }
  cv::Mat mask;
  if (k) {
    cv::findEssentialMat(pa, pb, cv::Mat(*k), cv::RANSAC, kRansacProb,
                         kRansacPx, kRansacIters, mask);
  } else {
    cv::findFundamentalMat(pa, pb, cv::FM_RANSAC, kRansacPx, kRansacProb,
                           kRansacIters, mask);
  }
  return mask.empty() ? 0 : cv::countNonZero(mask);
}

// --- one dataset, one alternative -------------------------------------------

struct Row {
  std::string dataset;
  std::string method;
  double detect_ms = 0, match_ms = 0, verify_ms = 0;
  double keypoints = 0, putative = 0, inliers = 0;
  double inliers_next = 0, inliers_skip = 0;  // pairs (i, i+1) and (i, i+2)
  double median_ratio = 0;
  int good_pairs = 0, pairs = 0;
};

struct PairResult {
  int gap;
  double match_ms, verify_ms;
  int putative, inliers;
};

// Wall clock, or the CPU time of all this process's threads: that counts
// only the cycles the process got, so it stays steady when other processes
// load the machine (it sums both threads, so it is not a latency).
double now_ms(bool cpu) {
  if (cpu) return 1000.0 * static_cast<double>(std::clock()) / CLOCKS_PER_SEC;
  return std::chrono::duration<double, std::milli>(
             Clock::now().time_since_epoch())
      .count();
}

// Runs fn `repeat` times and returns the fastest run in ms: on a shared
// machine the minimum is the estimate least disturbed by other processes.
// Every alternative is deterministic, so each run produces the same output.
template <typename Fn>
double fastest_ms(const Timing& timing, Fn&& fn) {
  double best = 0.0;
  for (int i = 0; i < timing.repeat; ++i) {
    const double start = now_ms(timing.cpu);
    fn();
    const double ms = now_ms(timing.cpu) - start;
    if (i == 0 || ms < best) best = ms;
  }
  return best;
}

std::vector<Features> extract_all(const Dataset& ds, const Extractor& extract,
                                  const Timing& timing, Row& row) {
  extract(ds.images.front().gray);  // warm-up: allocations, thread pool
  std::vector<double> ms, counts;
  std::vector<Features> features;
  for (const auto& image : ds.images) {
    Features f;
    ms.push_back(fastest_ms(timing, [&] { f = extract(image.gray); }));
    counts.push_back(static_cast<double>(f.keypoints.size()));
    features.push_back(std::move(f));
  }
  row.detect_ms = mean(ms);
  row.keypoints = mean(counts);
  return features;
}

PairResult run_pair(const Features& a, const Features& b, int gap,
                    const std::optional<cv::Matx33d>& k, const Timing& timing) {
  PairResult r{gap, 0, 0, 0, 0};
  std::vector<cv::DMatch> matches;
  r.match_ms = fastest_ms(timing, [&] { matches = match_mutual(a, b); });
  r.verify_ms =
      fastest_ms(timing, [&] { r.inliers = count_inliers(a, b, matches, k); });
  r.putative = static_cast<int>(matches.size());
  return r;
}

void summarise(const std::vector<PairResult>& pairs, Row& row) {
  std::vector<double> match, verify, putative, inliers, ratio, next, skip;
  for (const auto& p : pairs) {
    match.push_back(p.match_ms);
    verify.push_back(p.verify_ms);
    putative.push_back(p.putative);
    inliers.push_back(p.inliers);
    ratio.push_back(p.putative > 0 ? static_cast<double>(p.inliers) / p.putative
                                   : 0.0);
    (p.gap == 1 ? next : skip).push_back(p.inliers);
    if (p.inliers >= kGoodPairInliers) ++row.good_pairs;
  }
  row.pairs = static_cast<int>(pairs.size());
  row.match_ms = mean(match);
  row.verify_ms = mean(verify);
  row.putative = mean(putative);
  row.inliers = mean(inliers);
  row.inliers_next = mean(next);
  row.inliers_skip = mean(skip);
  row.median_ratio = median(ratio);
}

Row run_method(const Dataset& ds, const std::string& method,
               const Config& cfg) {
  Row row;
  row.dataset = ds.name;
  row.method = method;
  const auto features =
      extract_all(ds, make_extractor(method, cfg), cfg.timing, row);
  std::vector<PairResult> pairs;
  for (int gap = 1; gap <= 2; ++gap) {
    for (size_t i = 0; i + static_cast<size_t>(gap) < features.size(); ++i) {
      pairs.push_back(
          run_pair(features[i], features[i + gap], gap, ds.k, cfg.timing));
    }
  }
  summarise(pairs, row);
  return row;
}

// --- output -----------------------------------------------------------------

void describe_dataset(const Dataset& ds, const Config& cfg) {
  std::vector<double> decode;
  for (const auto& image : ds.images) decode.push_back(image.decode_ms);
  const Image& first = ds.images.front();
  std::fprintf(stderr,
               "%s: %zu images in %s, %dx%d -> %dx%d, decode %.1f ms/img, "
               "%s\n",
               ds.name.c_str(), ds.images.size(),
               (fs::path(cfg.data_dir) / ds.folder).string().c_str(),
               first.original.width, first.original.height, first.gray.cols,
               first.gray.rows, mean(decode),
               ds.k ? "essential matrix (K known)" : "fundamental matrix");
}

void print_plain(const std::vector<Row>& rows) {
  std::printf("%-9s %-12s %9s %9s %9s %6s %8s %7s %6s %6s %6s %8s\n", "dataset",
              "method", "det ms", "match ms", "ransac ms", "kpts", "putative",
              "inliers", "inl+1", "inl+2", "ratio", ">=50");
  for (const auto& r : rows) {
    std::printf(
        "%-9s %-12s %9.1f %9.1f %9.1f %6.0f %8.0f %7.0f %6.0f %6.0f %6.2f "
        "%5d/%-3d\n",
        r.dataset.c_str(), r.method.c_str(), r.detect_ms, r.match_ms,
        r.verify_ms, r.keypoints, r.putative, r.inliers, r.inliers_next,
        r.inliers_skip, r.median_ratio, r.good_pairs, r.pairs);
  }
}

void print_markdown(const std::vector<Row>& rows) {
  std::printf(
      "| dataset | method | detect+describe ms/img | match ms/pair | "
      "RANSAC ms/pair | keypoints | putative | inliers | inliers (i,i+1) | "
      "inliers (i,i+2) | median inlier ratio | pairs >= 50 inliers |\n");
  std::printf("|---|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|\n");
  for (const auto& r : rows) {
    std::printf(
        "| %s | %s | %.1f | %.1f | %.1f | %.0f | %.0f | %.0f | %.0f | %.0f | "
        "%.2f | %d/%d |\n",
        r.dataset.c_str(), r.method.c_str(), r.detect_ms, r.match_ms,
        r.verify_ms, r.keypoints, r.putative, r.inliers, r.inliers_next,
        r.inliers_skip, r.median_ratio, r.good_pairs, r.pairs);
  }
}

// The "Parallel framework:" line of OpenCV's build information (TBB,
// pthreads, OpenMP...): it decides how --threads is honoured.
std::string parallel_framework() {
  const std::string info = cv::getBuildInformation();
  const std::string key = "Parallel framework:";
  const size_t at = info.find(key);
  if (at == std::string::npos) return "unknown parallel framework";
  const size_t from = info.find_first_not_of(' ', at + key.size());
  return info.substr(from, info.find('\n', from) - from);
}

int run(const Config& cfg) {
  if (!fs::is_directory(cfg.data_dir)) {
    std::fprintf(stderr,
                 "feature_bench: data directory %s not found; pass --data "
                 "DIR (the shared/data folder, see its README.md)\n",
                 cfg.data_dir.c_str());
    return 2;
  }
  for (const auto& m : cfg.methods) make_extractor(m, cfg);  // fail early
  cv::setNumThreads(cfg.threads);
  std::fprintf(stderr,
               "OpenCV %s, %s, %d threads, long side %d, %s, fastest of %d\n",
               CV_VERSION, parallel_framework().c_str(), cv::getNumThreads(),
               cfg.long_side, cfg.timing.cpu ? "CPU time" : "wall clock",
               cfg.timing.repeat);
  std::vector<Row> rows;
  for (const auto& name : cfg.datasets) {
    const Dataset ds = load_dataset(find_dataset(name), cfg);
    describe_dataset(ds, cfg);
    for (const auto& method : cfg.methods) {
      rows.push_back(run_method(ds, method, cfg));
      std::fprintf(stderr, "  %s done\n", method.c_str());
    }
  }
  if (cfg.markdown) {
    print_markdown(rows);
  } else {
    print_plain(rows);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Config cfg;
  CLI::App app{"feature_bench: detector/descriptor alternatives on real data"};
  app.add_option("--data", cfg.data_dir, "shared/data folder")
      ->capture_default_str();
  app.add_option("--datasets", cfg.datasets, "fountain,entry,temple,lund")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--methods", cfg.methods, "harris-sift,sift,orb,akaze")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--long-side", cfg.long_side, "working image long side, px")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--threads", cfg.threads, "cv::setNumThreads")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--harris-size", cfg.harris_size,
                 "SIFT keypoint size at Harris corners, px")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--repeat", cfg.timing.repeat,
                 "time each detect/match/RANSAC N times, keep the fastest")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_flag("--cpu-time", cfg.timing.cpu,
               "time with process CPU time (both threads summed), not wall");
  app.add_flag("--markdown", cfg.markdown, "print a Markdown table");
  CLI11_PARSE(app, argc, argv);
  try {
    return run(cfg);
  } catch (const std::exception& e) {  // cv::Exception derives from it
    std::fprintf(stderr, "feature_bench: %s\n", e.what());
    return 1;
  }
}
